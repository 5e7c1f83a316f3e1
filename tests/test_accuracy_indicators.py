"""Every run reports its own accuracy (issue 8, item 2).

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
from service.testing import run_inline_until_done

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

    from service.db import get_database
    from service.models import Run

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
