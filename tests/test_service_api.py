"""The REST API on SQLite and PostgreSQL: the contract, 422s naming the field, tokens, limits,
the result cache, run files and their series/frames, the dashboard page, migrations."""

from __future__ import annotations

import io

import pytest
import sqlalchemy as sa
from fastapi.testclient import TestClient

from service.app import create_app
from service.config import Limits, Settings
from harness import run_inline_until_done, sweep_doc

pytestmark = pytest.mark.timeout(120)


@pytest.fixture
def make_client(db_url, data_dir):
    def make(**kw):
        settings = Settings(data_dir=data_dir, db_url=db_url, **kw)
        return TestClient(create_app(settings))

    return make


def _fields(resp):
    assert resp.status_code == 422, resp.text
    return {d.get("field") or ".".join(str(x) for x in d["loc"][1:]) for d in resp.json()["detail"]}


def test_sweep_end_to_end(make_client, db_url, data_dir):
    c = make_client()
    doc = {"name": "rake-depth", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"tool.rake_angle_deg": {"values": [0, 10, 20, 30]}, "cut.depth_um": {"low": 25, "high": 150, "step": 62.5}},
           "design": "grid"}
    r = c.post("/api/studies", json=doc)
    assert r.status_code == 201, r.text
    st = r.json()
    assert {"id", "name", "kind", "status", "counts"} <= set(st) and st["status"] == "queued" and st["counts"]["queued"] == 12
    run_inline_until_done(db_url, data_dir, st["id"])
    st = c.get(f"/api/studies/{st['id']}").json()
    assert st["status"] == "done" and st["counts"]["done"] == 12 and st["progress"] == 1.0
    trials = c.get(f"/api/studies/{st['id']}/trials").json()
    assert len(trials) == 12
    assert {(t["params"]["tool.rake_angle_deg"], t["params"]["cut.depth_um"]) for t in trials} == {
        (a, d) for a in (0, 10, 20, 30) for d in (25.0, 87.5, 150.0)}
    t0 = trials[0]
    assert t0["status"] == "done" and t0["run_id"] and t0["metrics"]["cutting_force_N_per_mm"] > 0
    # metrics follow the parameters: MRR = depth x speed
    for t in trials:
        assert t["metrics"]["material_removal_rate_mm2_s"] == pytest.approx(t["params"]["cut.depth_um"] * 1e-3 * 18.33)
    run = c.get(f"/api/runs/{t0['run_id']}").json()
    assert run["status"] == "ok" and run["has_file"] and run["summary"]["status"] == "ok"
    h5 = c.get(f"/api/runs/{t0['run_id']}/result.h5")
    assert h5.status_code == 200 and h5.content[:8] == b"\x89HDF\r\n\x1a\n"
    import h5py

    with h5py.File(io.BytesIO(h5.content), "r") as f:
        assert f.attrs["status"] == "ok" and "scene" in f.attrs
    assert c.get(f"/api/runs/{t0['run_id']}/frames").json()["count"] == 0  # analytic runs store no frames
    assert "summary" in c.get(f"/api/runs/{t0['run_id']}/series").json()
    csv = c.get(f"/api/studies/{st['id']}/trials.csv")
    assert csv.status_code == 200 and csv.text.count("\n") == 13 and "tool.rake_angle_deg" in csv.text.splitlines()[0]
    assert any(s["id"] == st["id"] for s in c.get("/api/studies").json())


def test_result_cache_reuses_identical_scenes(make_client, db_url, data_dir):
    c = make_client()
    first = c.post("/api/studies", json=sweep_doc(5, "first")).json()["id"]
    run_inline_until_done(db_url, data_dir, first)
    second = c.post("/api/studies", json=sweep_doc(6, "second")).json()["id"]  # 5 identical scenes + 1 new
    run_inline_until_done(db_url, data_dir, second)
    st = c.get(f"/api/studies/{second}").json()
    assert st["status"] == "done" and st["counts"]["cached"] == 5 and st["counts"]["done"] == 6
    t1 = {t["index"]: t for t in c.get(f"/api/studies/{first}/trials").json()}
    t2 = c.get(f"/api/studies/{second}/trials").json()
    for t in t2[:5]:
        assert t["cached"] and t["run_id"] == t1[t["index"]]["run_id"]
    assert not t2[5]["cached"]
    assert len(list((data_dir / "runs").iterdir())) == 6


@pytest.mark.parametrize("patch, field", [
    ({"fixed": {"fidelity": "analytic", "tool.bogus": 1}}, "fixed.tool.bogus"),
    ({"fixed": {"fidelity": "analytic", "cut.depth_um": -5}}, "fixed.cut.depth_um"),
    ({"parameters": {"tool.rake_angle_deg": {"values": [0, 100]}}}, "parameters.tool.rake_angle_deg.values"),
    ({"parameters": {"tool.rake_angle_deg": {"low": 10, "high": 5}}}, "parameters.tool.rake_angle_deg"),
    ({"parameters": {"nope.x": {"values": [1]}}}, "parameters.nope.x"),
    ({"scene": "no-such-scene"}, "scene"),
    ({"scene": {"tool": {"rake_angle_deg": 99}}}, "scene.tool.rake_angle_deg"),
    ({"kind": "bake"}, "kind"),
    ({"parameters": {"tool.rake_angle_deg": {"low": 0, "high": 40, "step": 1e-300}}}, "parameters"),
    ({"parameters": {"cut.depth_um": {"low": 25, "high": 150, "step": 0.001}}}, "parameters"),
    ({"design": "lhs"}, "n_points"),
    ({"parameters": {"tool.rake_angle_deg": {"low": 0, "high": 30}}}, "parameters.tool.rake_angle_deg"),
    ({"kind": "optimize", "n_trials": 5}, "objectives"),
    ({"kind": "optimize", "n_trials": 5, "sampler": "simplex", "objectives": [{"metric": "thrust_force_N_per_mm"}]}, "sampler"),
    ({"kind": "optimize", "n_trials": 5, "objectives": [{"metric": "happiness"}]}, "objectives.0.metric"),
    ({"kind": "convergence", "parameters": {"tool.rake_angle_deg": {"values": [0, 10]}}}, "parameters.tool.rake_angle_deg"),
])
def test_invalid_documents_answer_422_naming_the_field(make_client, patch, field):
    c = make_client()
    doc = {**sweep_doc(3, "bad"), **patch}
    fields = _fields(c.post("/api/studies", json=doc))
    assert any(f == field or f.startswith(field + ".") or field.startswith(f) for f in fields), (fields, field)


def test_limits_and_token(db_url, data_dir):
    c = TestClient(create_app(Settings(data_dir=data_dir, db_url=db_url, api_token="s3cret",
                                       limits=Limits(max_jobs_per_study=50, max_body_bytes=20_000))))
    doc = sweep_doc(3, "t")
    assert c.post("/api/studies", json=doc).status_code == 401
    assert c.post("/api/studies", json=doc, headers={"Authorization": "Bearer wrong"}).status_code == 401
    auth = {"Authorization": "Bearer s3cret"}
    r = c.post("/api/studies", json=doc, headers=auth)
    assert r.status_code == 201
    assert c.post(f"/api/studies/{r.json()['id']}/cancel").status_code == 401
    assert c.post(f"/api/studies/{r.json()['id']}/cancel", headers=auth).json()["status"] == "cancelled"
    assert c.get(f"/api/studies/{r.json()['id']}").status_code == 200  # reads need no token
    assert "n_points" in str(c.post("/api/studies", json={**doc, "design": "lhs", "n_points": 51}, headers=auth).json())
    big = {**doc, "name": "x", "fixed": {"fidelity": "analytic"}, "parameters": {"tool.rake_angle_deg": {"values": [0.5] * 5000}}}
    assert c.post("/api/studies", json=big, headers=auth).status_code == 413
    grid = {**doc, "parameters": {"tool.rake_angle_deg": {"values": list(range(0, 40))},
                                  "cut.depth_um": {"values": [50, 60]}}}
    assert _fields(c.post("/api/studies", json=grid, headers=auth)) == {"parameters"}


def test_lhs_and_sobol_designs_cover_the_ranges(make_client):
    c = make_client()
    for design in ("lhs", "sobol"):
        doc = {**sweep_doc(1, design), "design": design, "n_points": 16, "seed": 4,
               "parameters": {"tool.rake_angle_deg": {"low": 0, "high": 40}, "cut.depth_um": {"low": 25, "high": 150, "log": True}}}
        sid = c.post("/api/studies", json=doc).json()["id"]
        pts = [t["params"] for t in c.get(f"/api/studies/{sid}/trials").json()]
        assert len(pts) == 16
        rake = sorted(p["tool.rake_angle_deg"] for p in pts)
        assert all(0 <= r <= 40 for r in rake) and all(25 <= p["cut.depth_um"] <= 150 for p in pts)
        if design == "lhs":  # one point in each of the 16 strata
            assert sorted(int(r // 2.5) for r in rake) == list(range(16))


def test_convergence_study_records_levels_and_errors(make_client, db_url, data_dir):
    c = make_client()
    doc = {"name": "conv", "kind": "convergence", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"numerics.element_size_um": {"values": [5, 2.5, 1.25]}}}
    sid = c.post("/api/studies", json=doc).json()["id"]
    run_inline_until_done(db_url, data_dir, sid)
    trials = c.get(f"/api/studies/{sid}/trials").json()
    assert len(trials) == 3 and all(t["wall_time_s"] is not None for t in trials)
    finest = [t for t in trials if t["params"]["numerics.element_size_um"] == 1.25][0]
    assert all(t["reference_job_id"] == finest["job_id"] for t in trials)
    assert finest["error_vs_finest"]["cutting_force_N_per_mm"] == 0.0
    assert all(set(t["error_vs_finest"]) >= {"cutting_force_N_per_mm", "thrust_force_N_per_mm"} for t in trials)


def test_health_scenes_dashboard_and_404s(make_client):
    c = make_client()
    h = c.get("/api/health").json()
    assert h["status"] == "ok" and h["database"] in ("sqlite", "postgresql")
    scenes = c.get("/api/scenes").json()
    assert {"seed-0deg-fem", "seed-0deg-fem-quick", "seed-90deg-hybrid-d01-quick"} <= {s["name"] for s in scenes}
    assert all({"name", "description", "fidelity", "scene"} <= set(s) for s in scenes)
    root = c.get("/")
    assert root.status_code == 200 and "html" in root.headers["content-type"]
    assert c.get("/docs").status_code == 200 and "/api/studies" in c.get("/openapi.json").json()["paths"]
    assert c.get("/api/studies/999999").status_code == 404
    assert c.get("/api/runs/" + "a" * 32).status_code == 404
    assert c.get("/api/runs/../../etc/passwd").status_code == 404
    assert c.get("/api/runs/" + "../" * 10 + "x/result.h5").status_code in (404, 422)
    assert c.post("/api/studies/999999/cancel").status_code == 404
    assert c.post("/api/studies", content=b"{not json", headers={"content-type": "application/json"}).status_code == 422


def test_migrations_match_the_models(db_url):
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext

    from store import get_database
    from store.migrate import upgrade
    from store.models import Base

    upgrade(db_url)
    with get_database(db_url).engine.connect() as conn:
        ctx = MigrationContext.configure(conn, opts={"include_object": lambda o, n, t, r, c: t != "table" or (n.startswith("fc_") and n != "fc_alembic_version")})
        diff = compare_metadata(ctx, Base.metadata)
    assert diff == []
    with get_database(db_url).engine.connect() as conn:
        assert conn.execute(sa.text("SELECT version_num FROM fc_alembic_version")).scalar() == "0001"
