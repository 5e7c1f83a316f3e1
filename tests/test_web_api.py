"""The dashboard's read-only endpoints (service/routers/dashboard.py): a run's context and mesh.

A study is created through the REST API (its jobs hold the validated scenes); a run of one of
its jobs is recorded with an HDF5 file written by solver.result, carrying a small mesh. The
answers must give back exactly what was stored: the job's scene and parameters, the study, the
mesh arrays. Unknown runs answer 404 and malformed ids 422; nothing answers 500.
"""

from __future__ import annotations

import time
import uuid

import numpy as np
import pytest
from fastapi.testclient import TestClient


@pytest.fixture
def client(tmp_path):
    from service.routers.dashboard import router
    from service.app import create_app
    from service.config import Settings

    app = create_app(Settings(data_dir=tmp_path))
    if "/api/runs/{run_id}/mesh" not in {getattr(r, "path", "") for r in app.routes}:
        app.include_router(router)
    with TestClient(app) as c:
        c.settings = app.state.settings
        c.db = app.state.db
        yield c


def _record_run(client, job_id: int | None, mesh: dict | None) -> str:
    from store.models import Run
    from solver.result import SOLVER_VERSION, Result
    from solver.scene import load_scene

    res = Result(scene=load_scene("seed-0deg-fem-quick"), status="ok")
    if mesh is not None:
        res.series["mesh"] = mesh
        res.frames, res.frame_times = [{"positions": np.stack([mesh["x"], mesh["y"]], 1)}], [1e-7]
    run_id = uuid.uuid4().hex
    res.write_hdf5(client.settings.runs_dir / f"{run_id}.h5")
    with client.db.write() as s:
        s.add(Run(id=run_id, job_id=job_id, scene_hash="test", solver_version=SOLVER_VERSION, status="ok", summary=res.summary(),
                  diagnosis=None, wall_time_s=0.0, has_file=True, created_at=time.time()))
    return run_id


def test_context_gives_the_study_the_parameters_and_the_scene_of_the_job(client):
    r = client.post("/api/studies", json={"name": "ctx", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
                                          "parameters": {"tool.rake_angle_deg": {"values": [5, 25]}}})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    trials = client.get(f"/api/studies/{sid}/trials").json()
    job = trials[1]
    run_id = _record_run(client, job["job_id"], None)
    ctx = client.get(f"/api/runs/{run_id}/context").json()
    assert ctx["study_id"] == sid and ctx["study_name"] == "ctx" and ctx["job_id"] == job["job_id"]
    assert ctx["params"] == {"tool.rake_angle_deg": 25}
    assert ctx["scene"]["tool"]["rake_angle_deg"] == 25 and ctx["scene"]["fidelity"] == "analytic"
    # a run without a job still answers, with no study
    lone = _record_run(client, None, None)
    ctx = client.get(f"/api/runs/{lone}/context").json()
    assert ctx["study_id"] is None and ctx["scene"] is None


def test_mesh_gives_back_the_stored_arrays(client):
    x, y = np.meshgrid(np.arange(3) * 1e-6, np.arange(2) * 1e-6)
    quads = np.array([[0, 1, 4, 3], [1, 2, 5, 4]])
    mesh = {"x": x.ravel(), "y": y.ravel(), "quads": quads, "material": np.array([0, 1], np.int8), "tool0": np.arange(12.0)}
    run_id = _record_run(client, None, mesh)
    got = client.get(f"/api/runs/{run_id}/mesh").json()
    assert got["quads"] == quads.tolist() and got["material"] == [0, 1]
    assert np.allclose(got["x"], mesh["x"]) and np.allclose(got["y"], mesh["y"]) and got["tool0"] == list(range(12))
    # the frames the dashboard draws on it
    assert client.get(f"/api/runs/{run_id}/frames").json()["count"] == 1


def test_missing_runs_and_meshes_answer_404_and_bad_ids_422(client):
    no_mesh = _record_run(client, None, None)
    assert client.get(f"/api/runs/{no_mesh}/mesh").status_code == 404
    assert client.get(f"/api/runs/{uuid.uuid4().hex}/mesh").status_code == 404
    assert client.get(f"/api/runs/{uuid.uuid4().hex}/context").status_code == 404
    for bad in ("..%2F..%2Fetc%2Fpasswd", "x" * 32, "ABCDEF" + "0" * 26):
        assert client.get(f"/api/runs/{bad}/mesh").status_code in (404, 422)
        assert client.get(f"/api/runs/{bad}/context").status_code in (404, 422)


def test_a_hybrid_frame_serves_its_particles_in_the_dashboards_shape(tmp_path):
    """A hybrid2d chip frame (written by solver.result with the coupler's particles_* arrays) comes
    back from the frame reader with ``particles.positions`` as (n, 2) rows, and material and damage
    of the same length: what web/static/views/frames.js draws."""
    from service.results import frame
    from solver.result import Result
    from solver.scene import load_scene

    r = Result(scene=load_scene("seed-0deg-hybrid-d01-quick"))
    n = 5
    px, py = np.linspace(0, 4e-6, n), np.linspace(1e-6, 2e-6, n)
    r.frames = [{"positions": np.zeros((4, 2)), "particles_x": px, "particles_y": py,
                 "particles_material": np.array([0, 1, 1, 0, 1], np.int32), "particles_damage": np.linspace(0, 1, n)}]
    r.frame_times = [1e-7]
    path = r.write_hdf5(tmp_path / "h.h5")
    fr = frame(path, 0)
    p = fr["particles"]
    assert p["positions"]["shape"] == [n, 2]
    assert np.allclose(np.array(p["positions"]["data"]), np.stack([px, py], 1))
    assert len(p["material"]["data"]) == n and len(p["damage"]["data"]) == n
    assert frame(path, 1) is None


def test_mesh_of_a_3d_run_is_its_side_view(client):
    """A 3D run's /mesh answers the faces of its side view (the section z = p/2 through the first fibres' axes),
    each naming its element, so the dashboard colours the faces by the frames' per-element fields."""
    from solver.fem3d.strip3d import StripSpec, build_strip, side_section

    strip = build_strip(StripSpec(0, L=30e-6, H=40e-6, mz_depth=10e-6, h=5e-6))
    run_id = _record_run(client, None, {**strip.series(), "tool0": np.arange(12.0)})
    got = client.get(f"/api/runs/{run_id}/mesh").json()
    quads, elems, zc = side_section(strip.X, strip.hexes, strip.info["pitch_m"])
    assert got["quads"] == quads.tolist() and got["elements"] == elems.tolist()
    assert len(got["material"]) == strip.n_elems and "side view" in got["section"]
    assert np.allclose(strip.X[2, np.unique(quads)], zc), "every face lies on the section plane"
    assert set(strip.material[elems]) >= {0, 1}, "the section cuts fibres and matrix"
