"""scripts/energy_budget.py: the tool's work per unit travel it reports is the mean cutting force over the cut."""

import importlib.util
from pathlib import Path

import h5py
import numpy as np
import pytest

from solver import load_scene, run

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "energy_budget.py"
SMALL = {"cut.depth_um": 30.0, "cut.length_um": 25.0, "tool.edge_radius_um": 5.0, "workpiece.height_um": 80.0,
         "workpiece.micro_zone_depth_um": 15.0, "numerics.element_size_um": 5.0, "numerics.elements_across_fibre": 3,
         "numerics.n_force_samples": 400, "numerics.n_frames": 0, "numerics.speed_scaling": 1000.0}


def _script():
    spec = importlib.util.spec_from_file_location("energy_budget", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_tool_work_over_the_travel_is_the_mean_cutting_force(tmp_path, capsys):
    r = run(load_scene("seed-0deg-fem-quick", SMALL))
    assert r.status == "ok", r.summary()
    path = str(r.write_hdf5(tmp_path / "r.h5"))
    module = _script()
    b = module.budget(path)
    with h5py.File(path, "r") as f:
        travel, fc = f["forces/travel_um"][:], f["forces/Fc"][:]
    work = np.trapezoid(fc * 1e3, travel * 1e-6)  # N/mm -> N/m over m of travel: J/m
    assert b["tool_work"] == pytest.approx(work, rel=0.05)
    assert b["residual"] == pytest.approx(0.0, abs=0.01 * b["tool_work"])
    assert module.main([path, path]) == 0
    assert "tool_work" in capsys.readouterr().out
    assert module.main([]) == 2
    assert module.main([str(tmp_path / "missing.h5")]) == 2
