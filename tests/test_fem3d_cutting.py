"""The fem3d fidelity end to end: the 3D strip cut by the extruded tool, its summary, HDF5, XDMF and plots.

A 2-um cut of the quick 0-degree strip (a few thousand steps): the run closes its energy balance, the tool
pushes on the workpiece (positive cutting force, penetration a small part of an element), the mesh is the
one the budget counted, and the frames are readable by a standard XDMF reader (meshio) as a time series
of hexahedra."""

import numpy as np
import pytest

from solver.budget import estimate
from solver.run import run
from solver.scene import load_scene


@pytest.fixture(scope="module")
def tiny_run():
    scene = load_scene("seed-0deg-fem3d-quick", {"cut.length_um": 2.0, "numerics.n_force_samples": 10,
                                                  "numerics.n_frames": 2})
    return scene, run(scene)


def test_tiny_cut_runs_and_balances_energy(tiny_run):
    scene, res = tiny_run
    assert res.status == "ok", res.diagnosis
    m = res.metrics
    assert m["energy_error"] < 1e-3
    assert m["peak_cutting_force_N_per_mm"] > 0.0, "the tool presses into the strip"
    assert m["max_penetration_fraction_of_element"] < 0.1
    assert m["n_elements"] == estimate(scene).elements
    assert m["strip_pitches"] == 1 and m["strip_width_um"] == pytest.approx(7.5 * np.sqrt(np.pi / 2.4), rel=1e-9)
    assert res.build["modules"][0] == "solver.fem3d.strip3d"


def test_hdf5_xdmf_and_plots(tiny_run, tmp_path):
    meshio = pytest.importorskip("meshio", reason="meshio is a test dependency (pyproject [test]); install .[test]")
    from solver.plots import plot_result

    scene, res = tiny_run
    h5 = res.write_hdf5(tmp_path / "run.h5")
    xdmf = h5.with_suffix(".xdmf")
    assert xdmf.is_file()
    with meshio.xdmf.TimeSeriesReader(xdmf) as reader:
        points, cells = reader.read_points_cells()
        assert points.shape == (res.metrics["n_nodes"], 3)
        assert cells[0].type == "hexahedron" and len(cells[0].data) == res.metrics["n_elements"]
        assert reader.num_steps == len(res.frames) == 2
        times = []
        for k in range(reader.num_steps):
            t, _, cell_data = reader.read_data(k)
            times.append(t)
            np.testing.assert_array_equal(cell_data["material"][0], res.frames[k]["material"])
        assert times == pytest.approx(res.frame_times)
    np.testing.assert_allclose(points, res.frames[0]["positions"])
    out = plot_result(h5, tmp_path / "run")
    assert any(p.name.endswith("_frames.png") for p in out)


def _bent_fibre_hourglass_share(n_quarter: int) -> float:
    """A fibre (the O-grid's fibre elements, 12 along 60 um) clamped at one end and bent quasi-statically by
    a tip deflection of 2 % of its length: hourglass / (stress work + hourglass)."""
    from solver.fem3d import loop, material3d as m3
    from solver.fem3d.strip3d import cell_section
    from solver.mesh import FIBRE

    d = 7.5e-6
    sec = cell_section(d * np.sqrt(np.pi / 2.4), d, n_quarter)
    q = sec.quads[sec.material == FIBRE]
    used = np.unique(q)
    remap = -np.ones(len(sec.pts), int)
    remap[used] = np.arange(len(used))
    pts, q, m = sec.pts[used], remap[q], len(used)
    L, nel = 60e-6, 12
    levels = np.linspace(0.0, L, nel + 1)
    X = np.vstack([np.repeat(levels[:, None], m, 1).ravel(), np.tile(pts[:, 0], nel + 1), np.tile(pts[:, 1], nel + 1)])
    hexes = np.vstack([np.hstack([k * m + q, (k + 1) * m + q]) for k in range(nel)])
    s = loop.build_state(X, hexes, [m3.fibre_stiffness(294e9, 14e9, 28e9, 0.2, 0.25, (1, 0, 0))], [1800.0], cfl=0.5,
                         hourglass_ratio_max=1.0)
    tip = X[0] > L - 1e-12
    s.fix[:, X[0] < 1e-12] = 1
    s.fix[1, tip] = 1
    s.damping = 2e7  # quasi-static
    T = 1000 * L / np.sqrt(294e9 / 1800.0)
    s.vp[1, tip] = 0.02 * L / T
    loop.advance(s, int(T / loop.stable_dt(s)))
    e = loop.energies(s)
    return e["hourglass"] / (e["internal"] + e["hourglass"])


@pytest.mark.parametrize("n_quarter", [1, 2])
def test_a_bent_fibre_stays_below_half_the_hourglass_guard(n_quarter):
    """The guard's limit on the strip (twice a bent fibre's hourglass share) leaves pure bending well inside it."""
    from solver.fem3d.engine import ogrid_hourglass_limit

    share = _bent_fibre_hourglass_share(n_quarter)
    n_across = 2 * n_quarter + 2
    assert 0.5 / n_across ** 2 < share < 2.0 / n_across ** 2, "about 1.5 / n^2 of the bending energy"
    assert share <= 0.5 * ogrid_hourglass_limit(n_across) + 1e-3
