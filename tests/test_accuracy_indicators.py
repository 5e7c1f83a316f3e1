"""Every run reports its own accuracy.

- A fem2d or hybrid2d summary carries the energy error, the kinetic/internal energy ratio (quasi-static
  check), the added mass of mass scaling, the maximum tool penetration, the hourglass energy
  ratio and the stable step with what limited it; each is finite and within its physical range.
- GET /api/runs/{id} adds ``estimated_discretisation_error`` when a convergence study of the
  same scene (apart from the varied field) exists: the error of the matching level against the
  study's finest level, or of the nearest coarser level for a resolution between levels.
"""

from __future__ import annotations

import math

import pytest
import sqlalchemy as sa
from fastapi.testclient import TestClient

from service.app import create_app
from service.config import Settings
from harness import run_inline_until_done

INDICATORS = ("energy_error", "kinetic_internal_ratio", "added_mass_fraction", "max_penetration_um",
              "hourglass_energy_ratio", "dt_s", "dt_limited_by")


@pytest.mark.timeout(300)
@pytest.mark.parametrize("base", ["seed-0deg-fem-quick", "seed-0deg-hybrid-d08-quick"])
def test_fem2d_and_hybrid2d_summaries_carry_every_accuracy_indicator(base):
    from solver import load_scene, run

    # a 5 um cut on a small workpiece, mass scaling 4 so that the added mass is not zero
    scene = load_scene(base, {"cut.length_um": 5.0, "numerics.n_frames": 0, "numerics.n_force_samples": 20,
                                               "workpiece.height_um": 150.0, "workpiece.micro_zone_depth_um": 30.0,
                                               "numerics.mass_scaling": 4.0})
    s = run(scene).summary()
    assert s["status"] == "ok", s.get("diagnosis")
    for key in INDICATORS:
        assert s.get(key) is not None, f"{key} missing from the summary"
    for key in INDICATORS[:-1]:
        assert math.isfinite(s[key]) and s[key] >= 0.0, (key, s[key])
    # mass scaling x4 adds three times the physical mass (the fraction is of the physical mass)
    assert s["added_mass_fraction"] == pytest.approx(3.0, rel=1e-6)
    assert s["hourglass_energy_ratio"] <= 1.0
    assert 1e-13 < s["dt_s"] < 1e-8  # a few-um element and km/s wave speeds
    assert isinstance(s["dt_limited_by"], str) and s["dt_limited_by"]
    assert s["max_penetration_um"] < scene.numerics.element_size_um  # the penalty keeps the tool out of the elements


# ----------------------------------------------------------------------------- the service
@pytest.fixture
def client(db_url, data_dir):
    return TestClient(create_app(Settings(data_dir=data_dir, db_url=db_url)))


def _run_study(c, db_url, data_dir, doc):
    r = c.post("/api/studies", json=doc)
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    run_inline_until_done(db_url, data_dir, sid)
    return sid, c.get(f"/api/studies/{sid}/trials").json()


@pytest.mark.timeout(180)
def test_run_answer_carries_the_estimated_discretisation_error(client, db_url, data_dir):
    c = client
    # the analytic fidelity keeps the study cheap; the runs' summaries are then edited to give known errors
    conv = {"name": "conv", "kind": "convergence", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
            "parameters": {"numerics.element_size_um": {"values": [5, 2.5, 1.25]}}}
    sid, trials = _run_study(c, db_url, data_dir, conv)
    by_h = {t["params"]["numerics.element_size_um"]: t for t in trials}
    assert set(by_h) == {5, 2.5, 1.25} and all(t["run_id"] for t in trials)

    from store import get_database
    from store.models import Run

    db = get_database(db_url)
    base = by_h[1.25]["metrics"]["thrust_force_N_per_mm"]
    with db.write() as s:  # coarse levels 20 % and 5 % off the finest one
        for h, factor in ((5, 1.2), (2.5, 1.05)):
            run = s.get(Run, by_h[h]["run_id"])
            run.summary = {**run.summary, "thrust_force_N_per_mm": base * factor}

    est = c.get(f"/api/runs/{by_h[5]['run_id']}").json()["estimated_discretisation_error"]
    assert est["study_id"] == sid and est["basis"] == "level" and est["level"] == {"numerics.element_size_um": 5.0}
    assert est["relative_error_vs_finest"]["thrust_force_N_per_mm"] == pytest.approx(0.2)
    est = c.get(f"/api/runs/{by_h[2.5]['run_id']}").json()["estimated_discretisation_error"]
    assert est["relative_error_vs_finest"]["thrust_force_N_per_mm"] == pytest.approx(0.05)
    est = c.get(f"/api/runs/{by_h[1.25]['run_id']}").json()["estimated_discretisation_error"]
    assert est["relative_error_vs_finest"]["thrust_force_N_per_mm"] == 0.0 and est["reference_job_id"] == by_h[1.25]["job_id"]

    # a run of the same scene between two levels: bounded by the nearest coarser level (2.5 um)
    between = {"name": "between", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
               "parameters": {"numerics.element_size_um": {"values": [2.0]}}, "design": "grid"}
    _, tr = _run_study(c, db_url, data_dir, between)
    est = c.get(f"/api/runs/{tr[0]['run_id']}").json()["estimated_discretisation_error"]
    assert est["basis"] == "nearest coarser level" and est["level"] == {"numerics.element_size_um": 2.5}
    assert est["relative_error_vs_finest"]["thrust_force_N_per_mm"] == pytest.approx(0.05)

    # another scene (a different rake angle): no convergence study of it, no estimate
    other = {"name": "other", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
             "parameters": {"tool.rake_angle_deg": {"values": [12.0]}}, "design": "grid"}
    _, tr = _run_study(c, db_url, data_dir, other)
    body = c.get(f"/api/runs/{tr[0]['run_id']}").json()
    assert body["status"] == "ok" and body["estimated_discretisation_error"] is None


@pytest.mark.timeout(180)
def test_convergence_study_with_replicas_compares_level_means_with_their_standard_errors(client, db_url, data_dir):
    """Each level runs ``replicas`` times with the speed scaling perturbed by k 1e-6; the trials carry
    the level's mean, standard error, the error of the mean against the finest mean and its
    uncertainty sqrt(sem^2 + sem_f^2) / |mean_f| (checked against values computed here)."""
    c = client
    conv = {"name": "conv-rep", "kind": "convergence", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
            "parameters": {"numerics.element_size_um": {"values": [5, 2.5]}}, "replicas": 3}
    sid, trials = _run_study(c, db_url, data_dir, conv)
    assert len(trials) == 6 and sorted(t["params"]["replica"] for t in trials) == [0, 0, 1, 1, 2, 2]
    from store import get_database
    from store.models import Job, Run

    db = get_database(db_url)
    with db.read() as s:
        speeds = sorted({s.get(Job, t["job_id"]).scene["numerics"]["speed_scaling"] for t in trials})
    from solver import load_scene

    base = load_scene("seed-0deg-fem-quick").numerics.speed_scaling
    assert speeds == pytest.approx([base, base * (1 + 1e-6), base * (1 + 2e-6)], rel=1e-12)  # three distinct scenes per level
    # known samples: h = 2.5 (finest) 10, 11, 12 -> mean 11, sd 1, sem 1/sqrt(3); h = 5: 12, 14, 16 -> mean 14, sd 2
    samples = {2.5: [10.0, 11.0, 12.0], 5: [12.0, 14.0, 16.0]}
    with db.write() as s:
        for t in trials:
            run = s.get(Run, t["run_id"])
            run.summary = {**run.summary, "thrust_force_N_per_mm": samples[t["params"]["numerics.element_size_um"]][t["params"]["replica"]]}
    trials = c.get(f"/api/studies/{sid}/trials").json()
    coarse = [t for t in trials if t["params"]["numerics.element_size_um"] == 5]
    fine = [t for t in trials if t["params"]["numerics.element_size_um"] == 2.5]
    m = "thrust_force_N_per_mm"
    for t in coarse:
        lv = t["level"]
        assert lv["replicas"] == 3 and lv["replicas_ok"] == 3 and not lv["is_finest"]
        assert lv["mean"][m] == pytest.approx(14.0) and lv["sd"][m] == pytest.approx(2.0)
        assert lv["sem"][m] == pytest.approx(2.0 / math.sqrt(3))
        assert t["error_vs_finest"][m] == pytest.approx(3.0 / 11.0)
        assert t["error_uncertainty"][m] == pytest.approx(math.sqrt(4.0 / 3 + 1.0 / 3) / 11.0)
    assert all(t["level"]["is_finest"] and t["error_vs_finest"][m] == 0.0 for t in fine)
    assert {t["reference_job_id"] for t in trials} == {next(t["job_id"] for t in fine if t["params"]["replica"] == 0)}
    # a run of the unperturbed coarse scene gets the level mean's error with its uncertainty
    first = next(t for t in coarse if t["params"]["replica"] == 0)
    est = c.get(f"/api/runs/{first['run_id']}").json()["estimated_discretisation_error"]
    assert est["relative_error_vs_finest"][m] == pytest.approx(3.0 / 11.0) and est["replicas"] == 3
    assert est["uncertainty"][m] == pytest.approx(math.sqrt(5.0 / 3) / 11.0)


def test_replicas_of_every_study_kind_count_against_the_job_limit(client):
    doc = {"name": "s", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"tool.rake_angle_deg": {"values": [10, 20]}}, "replicas": 2}
    r = client.post("/api/studies", json=doc)
    assert r.status_code == 201 and r.json()["planned_jobs"] == 4, r.text
    opt = {"name": "o", "kind": "optimize", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
           "parameters": {"tool.rake_angle_deg": {"low": 0, "high": 30}}, "n_trials": 60, "replicas": 100,
           "objectives": [{"metric": "thrust_force_N_per_mm"}]}
    r = client.post("/api/studies", json=opt)
    assert r.status_code == 422 and "6000 jobs" in r.text and "5000" in r.text, r.text
    doc = {"name": "c", "kind": "convergence", "scene": "seed-0deg-fem-quick",
           "parameters": {"numerics.element_size_um": {"values": [5, 2.5]}}, "replicas": 0}
    r = client.post("/api/studies", json=doc)
    assert r.status_code == 422 and "replicas" in r.text
    doc["replicas"] = 100
    doc["parameters"] = {"numerics.element_size_um": {"values": [round(0.3 * (i + 1), 2) for i in range(59)]}}  # 5900 jobs
    r = client.post("/api/studies", json=doc)
    assert r.status_code == 422 and "100 replicas" in r.text and "5000" in r.text
