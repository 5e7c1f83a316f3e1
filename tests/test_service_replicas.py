"""Replicated trials, confirmation and screening on a noisy metric whose true optimum is known.

The "solver" here is a function of the job's scene (harness.run_with_fake_solver): the
thrust force is 10 + (rake - 12)^2 / 16 N/mm plus Gaussian noise whose seed is the scene's hash,
so replica k (speed scaling x (1 + k 1e-6)) draws its own sample and a study without replicas sees
exactly replica 0's sample. The true optimum over rake in {0, 4, ..., 24} is 12 deg.
"""

from __future__ import annotations

import hashlib
import json
import math
import random
import statistics

import optuna
import pytest

from store.studies import optuna_name, optuna_storage
from store import replicas as rp
from service import studies
from service.config import Limits
from store import get_database
from store.migrate import upgrade
from store.models import Study
from service.report import study_out, trials
from store.documents import StudyIn
from harness import run_with_fake_solver

pytestmark = pytest.mark.timeout(300)

RAKES = [0, 4, 8, 12, 16, 20, 24]
NOISE_SD = 2.0


def true_thrust(rake: float) -> float:
    return 10.0 + (rake - 12.0) ** 2 / 16.0


def _seed(scene: dict, salt: str = "") -> int:
    return int(hashlib.sha256((json.dumps(scene, sort_keys=True) + salt).encode()).hexdigest()[:12], 16)


def noisy(scene: dict, params: dict, seed_salt: str = "", fail_replica: int | None = None):
    rake = scene["tool"]["rake_angle_deg"]
    if fail_replica is not None and params.get("replica") == fail_replica:
        return "failed", {"thrust_force_N_per_mm": 1e6, "cutting_force_N_per_mm": 1e6}
    rng = random.Random(_seed(scene, seed_salt))
    return "ok", {"thrust_force_N_per_mm": true_thrust(rake) + rng.gauss(0.0, NOISE_SD),
                  "cutting_force_N_per_mm": 20.0 + rng.gauss(0.0, 1.0)}


def _submit(db_url, doc):
    upgrade(db_url)
    return studies.create_study(get_database(db_url), StudyIn.model_validate(doc), Limits())


def _out(db_url, sid):
    db = get_database(db_url)
    with db.read() as s:
        st = s.get(Study, sid)
        return study_out(s, st), trials(s, st)


def _sweep(name, replicas, salt, **extra):
    return {"name": name, "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
            "parameters": {"tool.rake_angle_deg": {"values": RAKES}}, "replicas": replicas,
            "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}], **extra}


def test_standard_errors_are_sample_standard_errors_and_failed_replicas_stay_out():
    jobs = [{"status": "done", "metrics": {"f": v}} for v in (1.0, 2.0, 4.0, 7.0)]
    jobs.append({"status": "failed", "metrics": {"f": 1000.0}})
    agg = rp.aggregate(jobs, ["f"])
    assert agg["replicas"] == 5 and agg["replicas_ok"] == 4 and agg["replicas_failed"] == 1
    assert agg["mean"]["f"] == pytest.approx(3.5)
    assert agg["sd"]["f"] == pytest.approx(statistics.stdev([1.0, 2.0, 4.0, 7.0]))  # n - 1
    assert agg["sem"]["f"] == pytest.approx(statistics.stdev([1.0, 2.0, 4.0, 7.0]) / 2.0)
    assert agg["n"]["f"] == 4
    one = rp.aggregate([{"status": "done", "metrics": {"f": 3.0}}], ["f"])
    assert one["mean"]["f"] == 3.0 and one["sd"]["f"] is None and one["sem"]["f"] is None


def _find_salt():
    """A noise realisation in which the single samples (replica 0) rank a wrong rake angle best."""
    from service.studies import replicated
    from store.studies import _base_scene, build_scene

    doc = StudyIn.model_validate(_sweep("probe", 1, ""))
    base = build_scene(_base_scene(doc), doc.fixed).model_dump(mode="json")
    from solver.scene import scene_from_dict

    for k in range(200):
        salt = f"s{k}"
        vals = {}
        for params, over in replicated([{"tool.rake_angle_deg": r} for r in RAKES], base, 1):
            scene = scene_from_dict(base, over).model_dump(mode="json")
            vals[params["tool.rake_angle_deg"]] = noisy(scene, params, salt)[1]["thrust_force_N_per_mm"]
        if min(vals, key=vals.get) != 12:
            return salt
    raise AssertionError("no noise realisation fooled the single samples")


def test_single_samples_pick_a_wrong_optimum_replicated_means_the_right_one(sqlite_url):
    salt = _find_salt()
    single = _submit(sqlite_url, _sweep("single", 1, salt))
    run_with_fake_solver(sqlite_url, single, lambda sc, p: noisy(sc, p, salt))
    out1, _ = _out(sqlite_url, single)
    assert out1["status"] == "done"
    assert out1["best"][0]["params"]["tool.rake_angle_deg"] != 12  # the luckiest sample wins

    many = _submit(sqlite_url, _sweep("replicated", 24, salt))
    run_with_fake_solver(sqlite_url, many, lambda sc, p: noisy(sc, p, salt))
    out, rows = _out(sqlite_url, many)
    assert out["status"] == "done" and len(rows) == 24 * len(RAKES)
    best = out["best"][0]
    assert best["params"]["tool.rake_angle_deg"] == 12
    # the reported mean and standard error are those of the replicas' samples
    samples = [r["metrics"]["thrust_force_N_per_mm"] for r in rows if r["params"]["tool.rake_angle_deg"] == 12]
    assert len(samples) == 24
    assert best["objectives"]["thrust_force_N_per_mm"] == pytest.approx(statistics.mean(samples))
    assert best["sem"]["thrust_force_N_per_mm"] == pytest.approx(statistics.stdev(samples) / math.sqrt(24))
    # tied: within two combined standard errors of the best, and nothing else
    ranking = out["ranking"]
    means = {r["params"]["tool.rake_angle_deg"]: r["aggregate"] for r in rows}
    m0, s0 = means[12]["mean"]["thrust_force_N_per_mm"], means[12]["sem"]["thrust_force_N_per_mm"]
    expect = sorted(r for r in RAKES if r != 12 and abs(means[r]["mean"]["thrust_force_N_per_mm"] - m0)
                    <= 2 * math.hypot(means[r]["sem"]["thrust_force_N_per_mm"], s0))
    assert sorted(json.loads(k.split(":", 1)[1])["tool.rake_angle_deg"] for k in ranking["tied"]) == expect
    assert sorted(t["params"]["tool.rake_angle_deg"] for t in best["tied"]) == expect
    # the far ends are resolved from the best: 0 and 24 deg are 9 N/mm worse
    assert 0 not in expect and 24 not in expect


def test_a_failed_replica_does_not_enter_the_mean(sqlite_url):
    sid = _submit(sqlite_url, _sweep("with-failures", 4, "f"))
    run_with_fake_solver(sqlite_url, sid, lambda sc, p: noisy(sc, p, "f", fail_replica=2))
    out, rows = _out(sqlite_url, sid)
    assert out["status"] == "done"
    for r in rows:
        agg = r["aggregate"]
        assert agg["replicas"] == 4 and agg["replicas_ok"] == 3
        ok = [q["metrics"]["thrust_force_N_per_mm"] for q in rows
              if q["params"]["tool.rake_angle_deg"] == r["params"]["tool.rake_angle_deg"] and q["status"] == "done"]
        assert len(ok) == 3 and agg["mean"]["thrust_force_N_per_mm"] == pytest.approx(statistics.mean(ok))
        assert agg["mean"]["thrust_force_N_per_mm"] < 100  # the failed replica's 1e6 is not in it


def test_optimize_tells_optuna_the_mean_with_metric_names_and_replica_attributes(db_url):
    doc = {"name": "opt-replicas", "kind": "optimize", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"tool.rake_angle_deg": {"values": RAKES}}, "sampler": "tpe", "n_trials": 12, "parallelism": 3,
           "seed": 3, "replicas": 5, "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}]}
    sid = _submit(db_url, doc)
    run_with_fake_solver(db_url, sid, lambda sc, p: noisy(sc, p, "o", fail_replica=4))
    out, rows = _out(db_url, sid)
    assert out["status"] == "done" and len(rows) == 12 * 5
    st = optuna.load_study(study_name=optuna_name(sid), storage=optuna_storage(get_database(db_url)))
    assert st.metric_names == ["thrust_force_N_per_mm"]
    assert len(st.trials) == 12
    for t in st.trials:
        assert t.state == optuna.trial.TrialState.COMPLETE
        mine = [r for r in rows if r["trial_number"] == t.number]
        ok = [r["metrics"]["thrust_force_N_per_mm"] for r in mine if r["status"] == "done"]
        assert len(mine) == 5 and len(ok) == 4
        assert t.value == pytest.approx(statistics.mean(ok))
        assert t.user_attrs["replicas"] == 5 and t.user_attrs["replicas_ok"] == 4
        assert t.user_attrs["mean"]["thrust_force_N_per_mm"] == pytest.approx(statistics.mean(ok))
        assert t.user_attrs["sem"]["thrust_force_N_per_mm"] == pytest.approx(statistics.stdev(ok) / 2.0)
    best = out["best"][0]
    assert best["objectives"]["thrust_force_N_per_mm"] == pytest.approx(st.best_value)
    assert best["sem"]["thrust_force_N_per_mm"] > 0 and best["replicas_ok"] == 4
    assert isinstance(best["tied"], list)


def _two_fidelities(scene: dict, params: dict):
    """The analytic fidelity's optimum is at 19 deg, the numerical one's at 12 deg (noise-free
    here apart from a little spread, so the ranking is certain)."""
    rake = scene["tool"]["rake_angle_deg"]
    rng = random.Random(_seed(scene))
    if scene["fidelity"] == "analytic":
        return "ok", {"thrust_force_N_per_mm": 10.0 + (rake - 19.0) ** 2 / 16.0 + rng.gauss(0, 0.01)}
    return "ok", {"thrust_force_N_per_mm": 12.0 + (rake - 12.0) ** 2 / 16.0 + rng.gauss(0, 0.05)}


def test_confirmation_reranks_the_best_trials(db_url):
    doc = _sweep("confirmed", 2, "", confirm={"top_k": 3, "replicas": 3, "fidelity": "fem2d"})
    sid = _submit(db_url, doc)
    run_with_fake_solver(db_url, sid, _two_fidelities)
    out, rows = _out(db_url, sid)
    assert out["status"] == "done"
    conf = out["confirmation"]
    assert conf["status"] == "done" and len(conf["trials"]) == 3
    # the search (analytic) picked 20 best, then 16 and 24; on fem2d 16 is the best of those three
    by_search = sorted(conf["trials"], key=lambda r: r["search"]["rank"])
    assert [r["params"]["tool.rake_angle_deg"] for r in by_search] == [20, 16, 24]
    assert [r["params"]["tool.rake_angle_deg"] for r in conf["trials"]] == [16, 20, 24]
    assert conf["reranked"] is True
    best = out["best"][0]
    assert best["confirmed"] is True and best["stage"] == "confirm" and best["params"]["tool.rake_angle_deg"] == 16
    assert best["replicas"] == 3
    confirm_rows = [r for r in rows if r["stage"] == "confirm"]
    assert len(confirm_rows) == 9
    db = get_database(db_url)
    from store.models import Job

    with db.read() as s:
        scenes = [j.scene for j in s.query(Job).filter(Job.study_id == sid).all() if (j.params or {}).get("stage") == "confirm"]
    assert {sc["fidelity"] for sc in scenes} == {"fem2d"}


def test_optimize_confirmation_on_another_scene(sqlite_url):
    doc = {"name": "opt-confirm", "kind": "optimize", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic", "numerics.n_frames": 0},
           "parameters": {"tool.rake_angle_deg": {"values": RAKES}}, "n_trials": 10, "parallelism": 4, "seed": 1, "replicas": 2,
           "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}],
           "confirm": {"top_k": 2, "replicas": 4, "scene": "seed-0deg-hybrid-d01-quick"}}
    sid = _submit(sqlite_url, doc)
    run_with_fake_solver(sqlite_url, sid, _two_fidelities)
    out, rows = _out(sqlite_url, sid)
    assert out["status"] == "done"
    assert out["confirmation"]["status"] == "done" and len(out["confirmation"]["trials"]) == 2
    from store.models import Job

    with get_database(sqlite_url).read() as s:
        scenes = [j.scene for j in s.query(Job).filter(Job.study_id == sid).all() if (j.params or {}).get("stage") == "confirm"]
    assert len(scenes) == 8 and {sc["fidelity"] for sc in scenes} == {"hybrid2d"}
    assert {sc["numerics"]["n_frames"] for sc in scenes} == {0}  # the study's fixed fields apply, its fidelity does not


def test_screen_then_refine_inside_the_box_and_agreement(sqlite_url):
    """Screen on the analytic fidelity (optimum 19 deg), refine on fem2d inside the box around
    the screening's top trials; both fidelities share the refined points."""
    doc = {"name": "screened", "kind": "optimize", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "fem2d"},
           "parameters": {"tool.rake_angle_deg": {"low": -20, "high": 40}}, "n_trials": 8, "parallelism": 4, "seed": 2,
           "replicas": 2, "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}],
           "screen": {"fidelity": "analytic", "n_trials": 40, "top_k": 5, "margin": 0.05}}
    sid = _submit(sqlite_url, doc)
    run_with_fake_solver(sqlite_url, sid, _two_fidelities)
    out, rows = _out(sqlite_url, sid)
    assert out["status"] == "done"
    scr = out["screening"]
    lo, hi = scr["box"]["tool.rake_angle_deg"]["low"], scr["box"]["tool.rake_angle_deg"]["high"]
    assert -20 < lo < 19 < hi < 40 and hi - lo < 30
    search = [r for r in rows if r["stage"] == "search"]
    assert len(search) == 16 and all(lo <= r["params"]["tool.rake_angle_deg"] <= hi for r in search)
    assert len([r for r in rows if r["stage"] == "screen"]) == 40
    assert len([r for r in rows if r["stage"] == "check"]) == 8
    ag = scr["agreement"]["thrust_force_N_per_mm"]
    assert ag["n"] == 8 and scr["shared_points"] == 8
    pairs = {}
    for r in rows:
        if r["stage"] in ("search", "check"):
            pairs.setdefault(r["trial_number"], {}).setdefault(r["stage"], []).append(r["metrics"]["thrust_force_N_per_mm"])
    offsets = [statistics.mean(v["search"]) - v["check"][0] for v in pairs.values()]
    assert ag["mean_offset"] == pytest.approx(statistics.mean(offsets))
    assert ag["spearman"] is not None and -1 <= ag["spearman"] <= 1


@pytest.mark.parametrize("bad, where", [
    ({"replicas": 0}, "replicas"),
    ({"confirm": {"top_k": 2, "fidelity": "fem9d"}}, "confirm"),
    ({"confirm": {"top_k": 2, "scene": "no-such-scene"}}, "confirm.scene"),
    ({"screen": {"fidelity": "analytic", "n_trials": 10}}, "screen"),
    ({"objectives": []}, "objectives"),
])
def test_bad_stage_documents_answer_422_naming_the_field(sqlite_url, data_dir, bad, where):
    from fastapi.testclient import TestClient

    from service.app import create_app
    from service.config import Settings

    client = TestClient(create_app(Settings(data_dir=data_dir, db_url=sqlite_url)))
    doc = _sweep("bad", 2, "", confirm={"top_k": 2}) | bad
    r = client.post("/api/studies", json=doc)
    assert r.status_code == 422, r.text
    fields = [d.get("field") or ".".join(str(x) for x in d["loc"][1:]) for d in r.json()["detail"]]
    assert any(f.startswith(where) for f in fields), fields


def test_points_csv_and_status_text_carry_means_and_standard_errors(sqlite_url, data_dir):
    import csv
    import io

    from fastapi.testclient import TestClient

    from service.app import create_app
    from service.config import Settings
    from cli.study_text import summary_lines

    sid = _submit(sqlite_url, _sweep("csv", 3, "c"))
    run_with_fake_solver(sqlite_url, sid, lambda sc, p: noisy(sc, p, "c"))
    client = TestClient(create_app(Settings(data_dir=data_dir, db_url=sqlite_url)))
    rows = list(csv.DictReader(io.StringIO(client.get(f"/api/studies/{sid}/points.csv").text)))
    assert len(rows) == len(RAKES)
    trials_ = client.get(f"/api/studies/{sid}/trials").json()
    for r in rows:
        samples = [t["metrics"]["thrust_force_N_per_mm"] for t in trials_ if t["params"]["tool.rake_angle_deg"] == float(r["tool.rake_angle_deg"])]
        assert float(r["thrust_force_N_per_mm_mean"]) == pytest.approx(statistics.mean(samples))
        assert float(r["thrust_force_N_per_mm_sem"]) == pytest.approx(statistics.stdev(samples) / math.sqrt(3))
        assert r["replicas_ok"] == "3"
    assert client.get(f"/api/studies/{sid}/trials?limit=5&offset=2").json() == trials_[2:7]
    page = client.get(f"/api/studies/{sid}/points?limit=3&offset=3").json()
    assert page["total"] == len(RAKES) and len(page["points"]) == 3
    lines = summary_lines(client.get(f"/api/studies/{sid}").json())
    assert lines[0].startswith("  best: point") and "+-" in lines[0] and "mean of 3/3 replicas" in lines[0]
    assert lines[1].startswith("  statistically tied with it")


def test_confirmation_replicas_are_fresh_samples():
    from store.driver import trial_jobs
    from store.studies import stage_scene

    doc = StudyIn.model_validate(_sweep("fresh", 3, "", confirm={"top_k": 1, "replicas": 2}))
    base = stage_scene(doc, "search")
    search = trial_jobs(doc, "search", {"tool.rake_angle_deg": 10}, base)
    confirm = trial_jobs(doc, "confirm", {"tool.rake_angle_deg": 10}, stage_scene(doc, "confirm"))
    assert [p["replica"] for p, _ in search] == [0, 1, 2] and [p["replica"] for p, _ in confirm] == [3, 4]
    ss_search = {o["numerics.speed_scaling"] for _, o in search}
    ss_confirm = {o["numerics.speed_scaling"] for _, o in confirm}
    assert len(ss_confirm) == 2 and not ss_search & ss_confirm
    one = StudyIn.model_validate(_sweep("fresh1", 1, "", confirm={"top_k": 1, "replicas": 1}))
    (p1, o1), = trial_jobs(one, "confirm", {"tool.rake_angle_deg": 10}, stage_scene(one, "confirm"))
    assert p1["replica"] == 1 and o1["numerics.speed_scaling"] != base["numerics"]["speed_scaling"]
