"""Leave out what a scene does not need on tiny scenes.

- a classic-FEM scene builds no particles and runs no SPH kernel (no neighbour search);
- a scene with numerics.n_frames = 0 writes no /frames group (and one with frames does);
- a scene without physics.cohesive_interface builds no cohesive elements or cohesive arrays.
(An analytic run imports no numba: tests/test_run_contract.py.)
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from solver import load_scene, run

pytestmark = pytest.mark.timeout(240)
ROOT = Path(__file__).resolve().parent.parent
TINY = {"cut.length_um": 4.0, "cut.depth_um": 30.0, "tool.edge_radius_um": 5.0, "workpiece.height_um": 60.0,
        "workpiece.micro_zone_depth_um": 15.0, "numerics.n_force_samples": 20, "numerics.n_frames": 0}


def test_classic_fem_builds_no_particles_and_runs_no_sph_kernel():
    code = f"""
import json, sys
from solver import load_scene, run
r = run(load_scene("seed-0deg-fem-quick", {TINY!r}))
# an SPH kernel that ran has a compiled (or cache-loaded) signature
ran = sorted(f"{{m}}.{{k}}" for m, mod in list(sys.modules.items()) if m.startswith("solver.sph")
             for k, v in vars(mod).items() if getattr(v, "signatures", None))
print(json.dumps({{"status": r.status, "build": r.build, "ran": ran,
                  "sph": sorted(m for m in sys.modules if m.startswith("solver.sph"))}}, default=str))
"""
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=200)
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["status"] in ("ok", "unstable"), got
    # no SPH kernel ran: no particle update, no cell lists, no neighbour search (the classic-FEM
    # engine, solver.fem.engine, imports no SPH module; were one imported, its kernels must not run)
    assert got["ran"] == [], got["ran"]
    assert not any("sph" in m for m in got["build"]["modules"])
    assert "particles" not in got["build"]["arrays"]
    assert got["build"]["arrays"]["mesh"]["bytes"] > 0 and got["build"]["arrays"]["engine_state"]["bytes"] > 0


def test_no_frames_asked_no_frames_written(tmp_path):
    for n_frames in (0, 2):
        r = run(load_scene("seed-0deg-fem-quick", {**TINY, "numerics.n_frames": n_frames}))
        assert r.status in ("ok", "unstable"), r.diagnosis
        path = r.write_hdf5(tmp_path / f"run{n_frames}.h5")
        with h5py.File(path, "r") as f:
            if n_frames == 0:
                assert "frames" not in f and "mesh" not in f
            elif r.status == "ok":
                assert "frames" in f and len(f["frames"]) == n_frames


def test_no_cohesive_interface_builds_no_cohesive_arrays():
    from solver import fem
    from solver.mesher import build_mesh

    scene = load_scene("seed-0deg-fem-quick", {**TINY, "physics.cohesive_interface": False})
    si = scene.si()
    mesh = build_mesh(si)
    assert mesh.n_cohesive == 0
    state = fem.build_state(mesh, si)
    coh_arrays = [v for k, v in vars(state).items() if isinstance(v, np.ndarray) and k in ("coh", "coh_elems", "dmg", "cstate", "wcoh")]
    assert coh_arrays and all(a.shape[0] == 0 for a in coh_arrays)
    assert state.dt_cohesive == float("inf")  # the penalty no longer limits the step
    with_coh = build_mesh(load_scene("seed-0deg-fem-quick", TINY).si())
    assert with_coh.n_cohesive > 0
    r = run(scene)
    assert r.build["arrays"]["mesh"]["n_cohesive"] == 0
    assert r.metrics["n_cohesive"] == 0 and "cohesive" not in str(r.metrics.get("dt_limited_by", ""))


def test_fragment_contact_arrays_come_only_with_deletions():
    """The fragment contact's arrays (exposed boundary, bins, per-node forces) are built at the first
    deleted element: none for a scene without element deletion or before anything failed."""
    no_del = run(load_scene("seed-0deg-fem-quick", {**TINY, "physics.element_deletion": False}))
    assert no_del.status in ("ok", "unstable"), no_del.diagnosis
    assert "fragment_contact" not in no_del.build["arrays"]
    assert no_del.metrics["fragment_contact"] == "off"
    # a cut that breaks things builds them, and says how often its boundary was rebuilt
    cut = run(load_scene("seed-0deg-fem-quick", {**TINY, "cut.length_um": 12.0, "cut.depth_um": 5.0}))
    assert cut.status == "ok" and cut.metrics["n_failed_elements"] > 0, (cut.diagnosis, cut.metrics["n_failed_elements"])
    fr = cut.build["arrays"]["fragment_contact"]
    assert fr["bytes"] > 0 and fr["rebuilds"] >= 1
