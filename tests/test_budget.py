"""solver.budget's estimate against the mesher: never below the real element count (the limit
must not let a larger scene through) and within a factor of two of it."""

import pytest

from solver.budget import Limits, check, estimate
from solver.mesher import build_mesh
from solver.scene import load_scene


@pytest.mark.parametrize("name, overrides", [
    ("seed-0deg-fem-quick", {}), ("seed-90deg-fem-quick", {}), ("seed-0deg-fem", {}),
    ("seed-0deg-fem-quick", {"workpiece.fibre_angle_deg": 30}), ("seed-0deg-fem-quick", {"workpiece.fibre_angle_deg": 135}),
    ("seed-0deg-fem-quick", {"numerics.element_size_um": 1.0}), ("seed-0deg-fem-quick", {"workpiece.height_um": 1000}),
])
def test_the_estimate_bounds_the_mesh_within_a_factor_of_two(name, overrides):
    scene = load_scene(name, overrides)
    mesh = build_mesh(scene.si())
    e = estimate(scene)
    assert mesh.n_elems <= e.elements <= 2 * mesh.n_elems, (mesh.n_elems, e)


def test_particles_only_for_the_hybrid_and_nothing_for_the_analytic_model():
    assert estimate(load_scene("seed-0deg-fem-quick")).particles == 0
    assert estimate(load_scene("seed-0deg-hybrid-d01-quick")).particles > 0
    assert estimate(load_scene("seed-0deg-fem-quick", {"fidelity": "analytic"})).elements == 0


def test_check_names_the_fields_and_the_estimate():
    scene = load_scene("seed-0deg-fem-quick", {"workpiece.height_um": 5000, "workpiece.length_um": 10000,
                                               "numerics.element_size_um": 0.25, "cut.length_um": 100})
    ((field, value, msg),) = check(scene, Limits())
    assert field == "numerics.element_size_um" and value == 0.25
    assert "workpiece.length_um = 10000" in msg and "elements" in msg and "MB" in msg
    assert check(load_scene("seed-0deg-fem"), Limits()) == []
