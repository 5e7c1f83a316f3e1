"""scripts/crack_ahead.py: the lift, opening and split it reads from a run's frames, checked on a frame in which
the layer above the cut plane is moved by a known amount over a known length."""

import importlib.util
from pathlib import Path

import h5py
import numpy as np
import pytest

from solver import load_scene, run

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "crack_ahead.py"
DEPTH = 30.0
SMALL = {"cut.depth_um": DEPTH, "cut.length_um": 25.0, "tool.edge_radius_um": 5.0, "workpiece.height_um": 80.0,
         "workpiece.length_um": 200.0, "workpiece.micro_zone_depth_um": 15.0, "numerics.element_size_um": 5.0,
         "numerics.elements_across_fibre": 3, "numerics.n_force_samples": 50, "numerics.n_frames": 2,
         "numerics.speed_scaling": 1000.0}
LIFT = 20.0  # um: more than the interface's opening at full separation, 2 G_Ic / sigma_max = 8.9 um
LIFTED_AHEAD = 80.0  # um: the layer is moved over this length ahead of the tool's front


def _script():
    spec = importlib.util.spec_from_file_location("crack_ahead", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def lifted(tmp_path_factory):
    """A small 0-degree run whose last frame is replaced by the reference mesh with the layer lifted by LIFT over
    LIFTED_AHEAD um ahead of the front, no damage and no stress; returns (path, front's x)."""
    r = run(load_scene("seed-0deg-fem-quick", SMALL))
    assert r.status == "ok", r.summary()
    path = r.write_hdf5(tmp_path_factory.mktemp("crack") / "r.h5")
    with h5py.File(path, "r+") as f:
        x, y = f["mesh/x"][:] * 1e6, f["mesh/y"][:] * 1e6
        coh = f["mesh/cohesive"][:]
        key = sorted(f["frames"])[-1]
        g = f["frames"][key]
        travel = float(np.interp(g.attrs["time"], f["forces/time"][:], f["forces/travel_um"][:]))
        front = x.max() - travel
        in_span = (x < front) & (x >= front - LIFTED_AHEAD)
        layer = y > -DEPTH + 1e-6
        on_cut = np.abs(y[coh[:, 2]] + DEPTH) < 1e-6  # the cut plane's cohesive elements: columns 2, 3 its upper face
        layer[coh[on_cut, 2:].ravel()] = True
        pos = np.stack([x, y], axis=1)
        pos[layer & in_span, 1] += LIFT
        g["positions"][...] = pos * 1e-6
        g["cohesive_damage"][...] = 0.0
        g["state"][...] = 0
        g["stress"][...] = 0.0
    return path, front


def test_the_lift_the_open_length_and_the_split_read_back(lifted):
    path, front = lifted
    _, rows = _script().frames(str(path))
    last = rows[-1]
    assert last["lift50_um"] == pytest.approx(LIFT, abs=1e-6)
    assert last["lift100_um"] == pytest.approx(0.0, abs=1e-6)
    # the farthest lifted node column lies within one element (5 um) of LIFTED_AHEAD ahead of the front
    assert LIFTED_AHEAD - 5.0 <= last["open_um"] <= LIFTED_AHEAD
    assert last["split_um"] == pytest.approx(DEPTH)
    assert last["damaged_um"] == 0.0
    assert last["fibre_t_pct"] == pytest.approx(0.0, abs=1e-9)


def test_replicas_average_and_a_bad_travel_list_is_refused(lifted, capsys):
    path, _ = lifted
    module = _script()
    travels = [r["travel_um"] for r in module.frames(str(path))[1]]
    at = 0.5 * (travels[0] + travels[-1])
    assert module.main([str(path), str(path), "--at", f"{at:.3f}"]) == 0
    out = capsys.readouterr().out
    assert "n = 2 replicas" in out
    row = out.strip().splitlines()[-1].split(" | ")
    assert float(row[0]) == pytest.approx(at, abs=0.05) and row[3].split("+-")[1].split("(")[0].strip() == "0.00"
    assert module.main([str(path), "--at", "ten"]) == 2
    assert "--at: 'ten'" in capsys.readouterr().err


def test_a_file_it_cannot_read_is_refused_with_what_is_needed(tmp_path, capsys):
    module = _script()
    assert module.main([str(tmp_path / "missing.h5")]) == 2
    assert "not a readable run file" in capsys.readouterr().err
