"""End to end with the FEM solver: a -quick fem2d scene (cut shortened to 10 um to keep the
test short) as a study job, run by a worker in a child process (process isolation), with its
progress stored while it runs and its HDF5 file served back through the API (series, frames)."""

from __future__ import annotations

import time

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from service.config import Settings
from harness import start_worker, stop_processes

pytestmark = pytest.mark.timeout(300)


def test_fem_quick_scene_through_the_service(sqlite_url, data_dir, tmp_path):
    c = TestClient(create_app(Settings(data_dir=data_dir, db_url=sqlite_url)))
    doc = {"name": "fem-e2e", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"numerics.n_frames": 2, "cut.length_um": 10.0},
           "parameters": {"tool.rake_angle_deg": {"values": [30]}}}
    r = c.post("/api/studies", json=doc)
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    # auto isolation: FEM runs in a child process; a short lease makes the heartbeat (progress, ETA) frequent
    # one numba thread: a worker per core is the pool's layout, and spinning threads suffer on a busy machine
    w = start_worker(sqlite_url, data_dir, tmp_path / "w.log", lease_s=0.9, exit_when_idle=True, env={"NUMBA_NUM_THREADS": "1"})
    seen = []  # progress and ETA stored while the job runs
    try:
        deadline = time.time() + 240
        while w.poll() is None and time.time() < deadline:
            t = c.get(f"/api/studies/{sid}/trials").json()[0]
            if t["status"] == "running" and 0 < t["progress"] < 1:
                seen.append((t["progress"], t["eta_s"]))
            time.sleep(0.5)
        w.wait(5)
    finally:
        stop_processes([w])
    assert seen, "no progress was stored while the FEM job ran"
    assert all(e is not None and e >= 0 for _, e in seen)
    assert [p for p, _ in seen] == sorted(p for p, _ in seen)  # the fraction of the cut only grows
    assert w.returncode == 0, (tmp_path / "w.log").read_text()[-3000:]
    (t,) = c.get(f"/api/studies/{sid}/trials").json()
    run = c.get(f"/api/runs/{t['run_id']}").json()
    assert run["status"] == "ok", run.get("diagnosis")
    assert t["status"] == "done" and t["progress"] == 1.0
    m = t["metrics"]
    assert m["cutting_force_N_per_mm"] is not None and m["steps"] > 0 and m["wall_time_s"] > 0
    series = c.get(f"/api/runs/{t['run_id']}/series", params={"max_points": 50}).json()
    f = series["forces"]
    assert 2 <= len(f["time"]) <= 50 and len(f["Fc"]) == len(f["time"]) == len(f["Ft"])
    assert series["summary"]["cutting_force_N_per_mm"] == pytest.approx(m["cutting_force_N_per_mm"])
    frames = c.get(f"/api/runs/{t['run_id']}/frames").json()
    assert frames["count"] == 2 and len(frames["times"]) == 2 and "positions" in frames["fields"]
    fr = c.get(f"/api/runs/{t['run_id']}/frames/1").json()
    assert fr["positions"]["shape"][-1] == 2 and len(fr["positions"]["data"]) == fr["positions"]["shape"][0]
    assert c.get(f"/api/runs/{t['run_id']}/frames/2").status_code == 404
    assert c.get(f"/api/studies/{sid}").json()["status"] == "done"
