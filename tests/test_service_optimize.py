"""Optimisation studies on the analytic model (optuna ask-and-tell driven by the service).

Known optima of the analytic model (solver/analytic.py), derived, not printed by the code:
- the thrust force grows with the edge radius (the pressing and bouncing regions scale with it),
  so minimising thrust over edge_radius_um in [2, 60] has its optimum at the lower bound 2 um;
- the cutting force grows with the depth of cut while the material removal rate is
  depth x speed; minimising the cutting force subject to MRR >= 1.2 mm2/s at 18.33 mm/s puts
  the optimum on the constraint: depth = 1.2 / (18.33e-3) = 65.47 um.
A two-objective study (min cutting force, max MRR over depth) answers a non-dominated front.
"""

from __future__ import annotations

import math

import optuna
import pytest
import sqlalchemy as sa

from store.studies import optuna_name, optuna_storage
from service import studies
from service.config import Limits
from store import get_database
from store.migrate import upgrade
from store.models import Job, Study
from service.report import trials
from store.documents import StudyIn
from harness import run_inline_until_done
from solver import load_scene, run

pytestmark = pytest.mark.timeout(240)

BASE = {"scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"}}


def _metric(overrides, key):
    return run(load_scene("seed-0deg-fem-quick", {"fidelity": "analytic", **overrides})).metrics[key]


def _submit(db_url, doc):
    upgrade(db_url)
    return studies.create_study(get_database(db_url), StudyIn.model_validate(doc), Limits())


def _trials(db_url, sid):
    db = get_database(db_url)
    with db.read() as s:
        return trials(s, s.get(Study, sid)), s.get(Study, sid).status


def test_premises_of_the_known_optima():
    # monotonic trends the optima rest on (checked on the model itself, over the searched ranges)
    thrust = [_metric({"tool.edge_radius_um": r}, "thrust_force_N_per_mm") for r in (2, 5, 10, 20, 40, 60)]
    assert all(b > a for a, b in zip(thrust, thrust[1:]))
    fc = [_metric({"cut.depth_um": d}, "cutting_force_N_per_mm") for d in (25, 50, 65.47, 80, 120, 150)]
    assert all(b > a for a, b in zip(fc, fc[1:]))


def test_minimise_thrust_over_edge_radius_finds_lower_bound(db_url, data_dir):
    doc = {**BASE, "name": "thrust-radius", "kind": "optimize", "sampler": "tpe", "n_trials": 20, "parallelism": 2, "seed": 7,
           "parameters": {"tool.edge_radius_um": {"low": 2, "high": 60}},
           "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}]}
    sid = _submit(db_url, doc)
    run_inline_until_done(db_url, data_dir, sid)
    rows, status = _trials(db_url, sid)
    assert status == "done" and len(rows) == 20 and all(r["status"] == "done" for r in rows)
    best = [r for r in rows if r["on_pareto_front"]]
    assert len(best) == 1
    r_best = best[0]["params"]["tool.edge_radius_um"]
    assert r_best <= 2 + 0.1 * 58, r_best  # within 10 % of the range from the optimum at 2 um
    t_min = _metric({"tool.edge_radius_um": 2}, "thrust_force_N_per_mm")
    t_max = _metric({"tool.edge_radius_um": 60}, "thrust_force_N_per_mm")
    assert best[0]["metrics"]["thrust_force_N_per_mm"] - t_min <= 0.1 * (t_max - t_min)
    # optuna (same database) agrees with the service
    st = optuna.load_study(study_name=optuna_name(sid), storage=optuna_storage(get_database(db_url)))
    assert len(st.trials) == 20 and all(t.state == optuna.trial.TrialState.COMPLETE for t in st.trials)
    assert math.isclose(st.best_value, best[0]["metrics"]["thrust_force_N_per_mm"])


def test_constrained_optimum_sits_on_the_constraint(sqlite_url, data_dir):
    d_star = 1.2 / (18.33e-3)
    doc = {**BASE, "name": "fc-mrr", "kind": "optimize", "sampler": "tpe", "n_trials": 30, "parallelism": 2, "seed": 3,
           "parameters": {"cut.depth_um": {"low": 25, "high": 150}},
           "objectives": [{"metric": "cutting_force_N_per_mm", "direction": "minimize"}],
           "constraints": [{"metric": "material_removal_rate_mm2_s", "op": ">=", "value": 1.2}]}
    sid = _submit(sqlite_url, doc)
    run_inline_until_done(sqlite_url, data_dir, sid)
    rows, status = _trials(sqlite_url, sid)
    assert status == "done"
    best = [r for r in rows if r["on_pareto_front"]]
    assert len(best) == 1 and best[0]["feasible"]
    d = best[0]["params"]["cut.depth_um"]
    assert d_star <= d <= d_star + 0.1 * (150 - 25), (d, d_star)
    infeasible = [r for r in rows if r["status"] == "done" and not r["feasible"]]
    assert all(r["metrics"]["material_removal_rate_mm2_s"] < 1.2 for r in infeasible)


def test_two_objectives_give_a_non_dominated_front(sqlite_url, data_dir):
    doc = {**BASE, "name": "pareto", "kind": "optimize", "sampler": "nsga2", "n_trials": 24, "parallelism": 4, "seed": 5,
           "parameters": {"cut.depth_um": {"low": 25, "high": 150}, "tool.rake_angle_deg": {"low": 0, "high": 40}},
           "objectives": [{"metric": "cutting_force_N_per_mm", "direction": "minimize"},
                          {"metric": "material_removal_rate_mm2_s", "direction": "maximize"}]}
    sid = _submit(sqlite_url, doc)
    run_inline_until_done(sqlite_url, data_dir, sid)
    rows, status = _trials(sqlite_url, sid)
    assert status == "done" and len(rows) == 24
    done = [r for r in rows if r["status"] == "done"]
    front = [r for r in done if r["on_pareto_front"]]
    assert len(front) >= 2

    def vec(r):
        return (r["metrics"]["cutting_force_N_per_mm"], -r["metrics"]["material_removal_rate_mm2_s"])

    def dominates(a, b):
        return all(x <= y for x, y in zip(a, b)) and any(x < y for x, y in zip(a, b))

    for f in front:  # nobody dominates a front member
        assert not any(dominates(vec(o), vec(f)) for o in done)
    for o in done:  # every other trial is dominated by some front member
        if not o["on_pareto_front"]:
            assert any(dominates(vec(f), vec(o)) or vec(f) == vec(o) for f in front)
    # the service's front is optuna's front
    st = optuna.load_study(study_name=optuna_name(sid), storage=optuna_storage(get_database(sqlite_url)))
    assert {t.number for t in st.best_trials} == {r["trial_number"] for r in front}


def test_cmaes_sampler_runs(sqlite_url, data_dir):
    doc = {**BASE, "name": "cmaes", "kind": "optimize", "sampler": "cmaes", "n_trials": 12, "parallelism": 3, "seed": 1,
           "parameters": {"tool.edge_radius_um": {"low": 2, "high": 60}, "tool.rake_angle_deg": {"low": 0, "high": 40}},
           "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}]}
    sid = _submit(sqlite_url, doc)
    run_inline_until_done(sqlite_url, data_dir, sid)
    rows, status = _trials(sqlite_url, sid)
    assert status == "done" and len(rows) == 12 and all(r["status"] == "done" for r in rows)


def test_failed_jobs_fail_their_trials(sqlite_url, data_dir):
    """The service's leases tell optuna the truth: a job out of attempts fails its trial."""
    from solver.result import SOLVER_VERSION
    from store import queue

    doc = {**BASE, "name": "truth", "kind": "optimize", "n_trials": 2, "parallelism": 1, "max_attempts": 1, "seed": 2,
           "parameters": {"tool.edge_radius_um": {"low": 2, "high": 60}},
           "objectives": [{"metric": "thrust_force_N_per_mm", "direction": "minimize"}]}
    sid = _submit(sqlite_url, doc)
    db = get_database(sqlite_url)
    c = queue.claim(db, "ghost", lease_s=0.01, solver_version=SOLVER_VERSION)
    assert c is not None
    import time

    time.sleep(0.05)
    run_inline_until_done(sqlite_url, data_dir, sid)  # reaps the lost job, runs the second trial
    rows, status = _trials(sqlite_url, sid)
    assert [r["status"] for r in rows] == ["failed", "done"] and status == "done"
    st = optuna.load_study(study_name=optuna_name(sid), storage=optuna_storage(db))
    states = [t.state for t in sorted(st.trials, key=lambda t: t.number)]
    assert states == [optuna.trial.TrialState.FAIL, optuna.trial.TrialState.COMPLETE]
    assert "max_attempts" in st.trials[0].user_attrs["fail_reason"]
    with db.read() as s:
        assert all(j.told for j in s.execute(sa.select(Job).where(Job.study_id == sid)).scalars())


def test_optuna_storage_created_by_many_processes_at_once(tmp_path):
    """The server and the workers may create optuna's tables in a fresh database at the same moment; every one
    of them gets a working storage (the loser of the version-stamp race retries)."""
    import subprocess
    import sys

    url = f"sqlite:///{tmp_path / 'race.db'}"
    code = ("import optuna, sys; from store.studies import _new_rdb_storage; "
            "s = _new_rdb_storage(optuna, sys.argv[1], {'connect_args': {'timeout': 60}}); "
            "print(len(s.get_all_studies()))")
    procs = [subprocess.Popen([sys.executable, "-c", code, url], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(6)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1][-500:] for o in outs]
    assert all(o[0].strip() == "0" for o in outs)
