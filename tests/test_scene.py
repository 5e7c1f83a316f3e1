"""The scene schema: defaults from the paper, SI conversion, dotted overrides, and bad input."""

import json
import math
import subprocess
import sys

import pytest

from cli.main import main
from solver.catalogue import CATALOGUE
from solver.scene import Scene, SceneError, load_scene, scene_from_dict

# (dotted overrides, field the message must name, a fragment the message must contain)
BAD_INPUTS = [
    ({"cut.depth_um": -5}, "cut.depth_um", "0 < depth_um"),
    ({"cut.depth_um": 0}, "cut.depth_um", "greater than 0"),
    ({"cut.depth_um": "nan"}, "cut.depth_um", "finite"),
    ({"cut.depth_um": float("inf")}, "cut.depth_um", "finite"),
    ({"cut.depth_um": "abc"}, "cut.depth_um", "valid number"),
    ({"cut.depth_um": 5000}, "cut.depth_um", "1000"),
    ({"cut.speed_mm_s": -1}, "cut.speed_mm_s", "greater than 0"),
    ({"cut.length_um": 0}, "cut.length_um", "greater than 0"),
    ({"tool.rake_angle_deg": 95}, "tool.rake_angle_deg", "<= 60"),
    ({"tool.rake_angle_deg": -60}, "tool.rake_angle_deg", "-45"),
    ({"tool.clearance_angle_deg": -2}, "tool.clearance_angle_deg", "0 <="),
    ({"tool.edge_radius_um": -1}, "tool.edge_radius_um", "0 <="),
    ({"tool.edge_radius_um": 150, "cut.depth_um": 1.5}, "tool.edge_radius_um", "10 x cut.depth_um"),
    ({"tool.friction": 3}, "tool.friction", "<= 2"),
    ({"tool.friction": [0.3]}, "tool.friction", "valid number"),
    ({"tool.colour": "red"}, "tool.colour", "unknown field"),
    ({"foo.bar": 1}, "foo.bar", "unknown field"),
    ({"workpiece.fibre_volume_fraction": 1.2}, "workpiece.fibre_volume_fraction", "0.85"),
    ({"workpiece.fibre_angle_deg": 200}, "workpiece.fibre_angle_deg", "180"),
    ({"workpiece.fibre_diameter_um": 0}, "workpiece.fibre_diameter_um", "1 <= fibre_diameter_um"),
    ({"workpiece.height_um": 20, "cut.depth_um": 50}, "cut.depth_um", "0.9 x workpiece.height_um"),
    ({"materials.matrix.nu": 0.5}, "materials.matrix.nu", "0.499"),
    ({"materials.fibre.E1_GPa": -294}, "materials.fibre.E1_GPa", "1 <= E1_GPa"),
    ({"materials.interface.GIc_N_mm": 0}, "materials.interface.GIc_N_mm", "1e-06 <= GIc_N_mm"),
    ({"materials.preset": "steel"}, "materials.preset", "t800s-m21-seed"),
    ({"materials.fibre.compressive_yield_MPa": 4000}, "materials.fibre.compressive_yield_MPa", "compressive strength"),
    ({"physics.sph_damage_matrix": 1.0}, "physics.sph_damage_matrix", "0.99"),
    ({"physics.cohesive_interface": "perhaps"}, "physics.cohesive_interface", "valid boolean"),
    ({"numerics.cfl": 0}, "numerics.cfl", "greater than 0"),
    ({"numerics.element_size_um": 0.01}, "numerics.element_size_um", "0.25"),
    ({"numerics.element_size_um": 20, "cut.depth_um": 10}, "numerics.element_size_um", "must not exceed cut.depth_um"),
    ({"numerics.elements_across_fibre": 2.5}, "numerics.elements_across_fibre", "integer"),
    ({"numerics.frame_fields": ["positions", "velocity"]}, "numerics.frame_fields", "positions"),
    ({"numerics.mass_scaling": 0.5}, "numerics.mass_scaling", "1 <= mass_scaling"),
    ({"fidelity": "cfd"}, "fidelity", "analytic"),
    ({"fidelity": "hybrid3d", "workpiece.fibre_angle_deg": 45}, "workpiece.fibre_angle_deg", "0 and 90 degrees"),
    ({"tool.rake_angle_deg": 60, "tool.clearance_angle_deg": 30}, "tool.clearance_angle_deg", "85 deg"),
    ({"workpiece.strip_pitches": 2}, "workpiece.strip_pitches", "3D strip"),
    ({"numerics.elements_round_fibre": 16}, "numerics.elements_round_fibre", "fidelity fem2d does not use it"),
    ({"fidelity": "fem3d", "workpiece.fibre_angle_deg": 45}, "workpiece.fibre_angle_deg", "0 and 90 degrees"),
    ({"fidelity": "fem3d", "workpiece.fibre_offset_um": 2}, "workpiece.fibre_offset_um", "allowed: 0"),
    ({"fidelity": "fem3d", "numerics.elements_round_fibre": 12}, "numerics.elements_round_fibre", "multiple of 8"),
    ({"fidelity": "fem3d", "workpiece.strip_pitches": 0}, "workpiece.strip_pitches", "1 <="),
    ({"fidelity": "fem3d", "workpiece.micro_zone_depth_um": 149}, "workpiece.micro_zone_depth_um", "above the bottom"),
]


@pytest.mark.parametrize("overrides,field,fragment", BAD_INPUTS, ids=[b[1] + "=" + str(list(b[0].values())[0]) for b in BAD_INPUTS])
def test_bad_input_names_field_value_and_allowed(overrides, field, fragment, capsys):
    argv = ["run", "seed-0deg-fem"]
    for k, v in overrides.items():
        argv += ["--set", f"{k}={json.dumps(v) if not isinstance(v, str) else v}"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert field in err and fragment in err, err


def test_bad_input_table_is_large_enough():
    assert len(BAD_INPUTS) >= 25


def test_scene_error_problems_are_structured():
    with pytest.raises(SceneError) as exc:
        load_scene("seed-0deg-fem", {"cut.depth_um": -5, "tool.friction": 9})
    fields = {p.field for p in exc.value.problems}
    assert fields == {"cut.depth_um", "tool.friction"}


def test_unknown_scene_and_unparsable_file(tmp_path, capsys):
    assert main(["run", "no-such-scene"]) == 2
    assert "no-such-scene" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("tool: [unclosed\n")
    assert main(["run", str(bad)]) == 2
    assert "not valid YAML" in capsys.readouterr().err
    listy = tmp_path / "list.yaml"
    listy.write_text("- 1\n- 2\n")
    assert main(["run", str(listy)]) == 2


def test_cli_exit_code_2_in_a_real_process():
    proc = subprocess.run([sys.executable, "-m", "cli.main", "run", "seed-0deg-fem", "--set", "cut.depth_um=-5"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "cut.depth_um" in proc.stderr and "-5" in proc.stderr


def test_defaults_are_the_papers_table_1_reading_b_with_the_2d_interface():
    s = Scene()
    f, m, i = s.materials.fibre, s.materials.matrix, s.materials.interface
    assert s.materials.preset == "t800s-m21-2d"
    assert (f.E1_GPa, f.E2_GPa, f.G12_GPa, f.G23_GPa, f.nu12, f.nu23) == (294, 14, 28, 5.5, 0.2, 0.25)
    # reading B: the fibre elastic to Xc, then plastic to the failure strain; 594.5 MPa the epoxy's compressive yield
    assert (f.Xt_GPa, f.Xc_GPa, f.compressive_yield_MPa, f.compressive_failure_strain) == (5.88, 3.288, 3288.0, 0.155)
    # the epoxy's moduli and compressive yield; the 2D-equivalent tensile yield with which the strip stack's
    # transverse cell reaches the ply's Y_T (the epoxy's own 74.7 MPa in the other presets)
    assert (m.law, m.E_GPa, m.nu, m.sigma_u_MPa, m.compressive_yield_MPa) == ("paraboloid", 2.96, 0.4, 95.0, 594.5)
    # the 2D-equivalent interface: the ply's strengths and toughnesses (docs/model.md)
    assert (i.normal_strength_MPa, i.shear_strength_MPa, i.GIc_N_mm, i.GIIc_N_mm) == (62.3, 92.3, 0.277, 0.788)
    for section in (s.workpiece, s.materials.fibre, s.materials.matrix, s.materials.interface, s.materials.ehm, s.tool,
                    s.cut, s.physics, s.numerics):
        for name, info in type(section).model_fields.items():
            assert info.description, f"{type(section).__name__}.{name} has no description"


def test_presets_fill_what_a_scene_does_not_set():
    seed = Scene.model_validate({"materials": {"preset": "t800s-m21-seed"}}).materials
    assert (seed.interface.shear_strength_MPa, seed.interface.GIc_N_mm, seed.interface.normal_strength_MPa) == (25, 0.05, 167.5)
    assert seed.matrix.law == "paraboloid" and seed.fibre.compressive_yield_MPa == 3288.0
    assert seed.matrix.sigma_u_MPa == 74.7  # the epoxy's (paper, Table 1) outside the 2D preset
    a = Scene.model_validate({"materials": {"preset": "t800s-m21-seed-reading-a"}}).materials
    assert (a.fibre.compressive_yield_MPa, a.matrix.law, a.matrix.fracture_energy_N_mm) == (594.5, "brittle", None)
    assert a.ehm.transverse_tensile_strength_MPa == 74.7
    # a field the scene sets wins over the preset's
    own = Scene.model_validate({"materials": {"preset": "t800s-m21-seed", "interface": {"shear_strength_MPa": 40}}}).materials
    assert own.interface.shear_strength_MPa == 40 and own.interface.GIc_N_mm == 0.05
    via_set = load_scene("seed-0deg-fem-quick", {"materials.preset": "t800s-m21-seed-reading-a"})
    assert via_set.materials.matrix.law == "brittle"
    with pytest.raises(SceneError, match="materials.preset"):
        load_scene("seed-0deg-fem-quick", {"materials.preset": "t300-914"})


def test_si_conversion_in_one_place():
    s = load_scene("seed-0deg-fem", {"cut.depth_um": 50, "tool.rake_angle_deg": 90 - 60, "cut.speed_mm_s": 1000})
    si = s.si()
    assert si.depth == pytest.approx(50e-6)
    assert si.rake == pytest.approx(math.radians(30))
    assert si.speed == pytest.approx(1.0)
    assert si.fibre.E1 == pytest.approx(294e9)
    assert si.matrix.sigma_u == pytest.approx(95e6)
    assert si.interface.GIc == pytest.approx(277.0)  # 0.277 N/mm = 277 J/m2
    assert si.interface.K == pytest.approx(1e15)  # 1e6 N/mm3 = 1e15 Pa/m


def test_catalogue_matches_the_paper():
    names = {"seed-0deg-fem", "seed-0deg-hybrid-d08", "seed-0deg-hybrid-d01", "seed-90deg-fem", "seed-90deg-hybrid-d01",
             "seed-0deg-fem3d", "seed-90deg-fem3d", "seed-0deg-hybrid3d-d08", "seed-0deg-hybrid3d-d01",
             "seed-90deg-hybrid3d-d01"}
    assert names | {n + "-quick" for n in names} == set(CATALOGUE)
    for angle in ("0", "90"):  # the 3D strip cuts the 2D scene's workpiece with the same tool and cut
        s2 = load_scene(f"seed-{angle}deg-fem", {"materials.preset": "t800s-m21-seed"})
        s3 = load_scene(f"seed-{angle}deg-fem3d")
        assert (s3.fidelity, s3.tool, s3.cut, s3.materials) == ("fem3d", s2.tool, s2.cut, s2.materials)
        h3 = load_scene(f"seed-{angle}deg-hybrid3d-d01-quick")  # the 3D hybrid: the fem3d scene with D as the 2D hybrids'
        f3 = load_scene(f"seed-{angle}deg-fem3d-quick")
        assert (h3.fidelity, h3.tool, h3.cut, h3.materials, h3.numerics) == ("hybrid3d", f3.tool, f3.cut, f3.materials, f3.numerics)
        assert (h3.physics.sph_damage_matrix, h3.physics.sph_damage_fibre) == (0.1, 0.8)
    assert load_scene("seed-0deg-hybrid3d-d08").physics.sph_damage_matrix == 0.8
    s0 = load_scene("seed-0deg-fem")
    assert (s0.workpiece.fibre_angle_deg, s0.tool.rake_angle_deg, s0.cut.depth_um, s0.cut.length_um) == (0, 30, 100, 200)
    assert (s0.tool.edge_radius_um, s0.tool.friction, s0.cut.speed_mm_s, s0.fidelity) == (20, 0.3, 18.33, "fem2d")
    s90 = load_scene("seed-90deg-hybrid-d01")
    assert (s90.workpiece.fibre_angle_deg, s90.tool.rake_angle_deg, s90.cut.depth_um) == (90, 10, 50)
    assert (s90.physics.sph_damage_matrix, s90.physics.sph_damage_fibre, s90.fidelity) == (0.1, 0.8, "hybrid2d")
    assert load_scene("seed-0deg-hybrid-d08").physics.sph_damage_matrix == 0.8
    for name in names:  # quick variants: same physics, coarser numerics
        full, quick = load_scene(name), load_scene(name + "-quick")
        assert quick.numerics.element_size_um > full.numerics.element_size_um
        assert quick.tool == full.tool and quick.materials == full.materials and quick.physics == full.physics


def test_scene_file_with_base_and_dotted_set(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text("base: seed-90deg-fem-quick\ntool:\n  rake_angle_deg: 5\n")
    s = load_scene(str(f), {"tool.friction": 0.5})
    assert (s.tool.rake_angle_deg, s.tool.friction, s.workpiece.fibre_angle_deg) == (5, 0.5, 90)


def test_canonical_json_is_stable_and_roundtrips():
    a = load_scene("seed-0deg-fem-quick")
    b = scene_from_dict(json.loads(a.model_dump_json()))
    assert a.canonical_json() == b.canonical_json()
    assert a.canonical_json() != load_scene("seed-0deg-fem-quick", {"tool.friction": 0.31}).canonical_json()


def test_scenes_command_lists_one_line_each(capsys):
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == len(CATALOGUE)
    assert all(line.split()[0] in CATALOGUE for line in lines)
