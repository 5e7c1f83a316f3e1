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
