"""The `fibrecut run` contract: JSON keys, HDF5 layout, and a run that never crashes its caller."""

import json
import math
import subprocess
import sys

import h5py
import numpy as np
import pytest

from cli.main import main
from solver import load_scene, run
from solver.result import CONTRACT_KEYS, Result, read_summary


def test_run_json_has_the_contract_keys_with_finite_values(tmp_path, capsys):
    out = tmp_path / "run.h5"
    assert main(["run", "seed-0deg-fem", "--set", "fidelity=analytic", "--json", "-o", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    for key in CONTRACT_KEYS:
        assert key in summary, key
    for key in ("cutting_force_N_per_mm", "thrust_force_N_per_mm", "damage_depth_um", "bounce_back_um",
                "energy_error", "wall_time_s"):
        assert isinstance(summary[key], float) and math.isfinite(summary[key]), (key, summary[key])
    assert summary["status"] == "ok" and isinstance(summary["warnings"], list)
    with h5py.File(out) as f:
        scene = json.loads(f.attrs["scene"])
        assert scene["fidelity"] == "analytic" and scene["cut"]["depth_um"] == 100
        assert json.loads(f.attrs["summary"])["cutting_force_N_per_mm"] == summary["cutting_force_N_per_mm"]
        assert f.attrs["status"] == "ok" and f.attrs["solver_version"] and f.attrs["host"]
        assert "frames" not in f  # the analytic model produces no chip frames


def test_hdf5_writes_only_what_exists_and_is_atomic(tmp_path):
    scene = load_scene("seed-0deg-fem-quick")
    r = Result(scene=scene, metrics={"cutting_force_N_per_mm": 1.0},
               series={"forces": {"time": np.arange(3.0), "Fc": np.ones(3), "Ft": np.zeros(3)}, "energies": {}},
               frames=[{"positions": np.zeros((4, 2))}], frame_times=[0.5])
    path = r.write_hdf5(tmp_path / "sub" / "r.h5")
    with h5py.File(path) as f:
        assert set(f) == {"forces", "frames"}  # empty groups are not written
        assert list(f["frames/0000"]) == ["positions"] and f["frames/0000"].attrs["time"] == 0.5
    assert read_summary(path)["cutting_force_N_per_mm"] == 1.0
    assert [p.name for p in path.parent.iterdir()] == ["r.h5"]  # no temporary file left behind


def test_a_failing_fidelity_reports_failed_instead_of_raising(monkeypatch):
    import solver.analytic

    def boom(scene):
        raise RuntimeError("deliberate")

    monkeypatch.setattr(solver.analytic, "run_analytic", boom)
    result = run(load_scene("seed-0deg-fem", {"fidelity": "analytic"}))
    assert result.status == "failed" and "deliberate" in result.diagnosis["what"]
    assert result.summary()["status"] == "failed"


def test_unknown_status_is_rejected():
    with pytest.raises(ValueError):
        Result(scene=load_scene("seed-0deg-fem"), status="fine")


def test_analytic_run_imports_no_numba():
    code = ("import sys; from solver import load_scene, run; "
            "r = run(load_scene('seed-0deg-fem', {'fidelity': 'analytic'})); "
            "assert r.status == 'ok', r.summary(); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numba', 'llvmlite', 'solver.fem')))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_compare_finds_the_papers_numbers_from_any_folder(tmp_path, monkeypatch):
    """`fibrecut compare` reads Table 2 from the copy the package ships (solver/reference/seed_results.json):
    from an unrelated folder it still works."""
    from cli import analysis as cli_analysis

    monkeypatch.chdir(tmp_path)
    ref = cli_analysis._reference(None)
    assert ref["cases"]["theta_0"]["thrust"]["classic_fem"] == -3.03
    assert ref["cases"]["theta_90"]["thrust"]["experiment"] == 59.29
