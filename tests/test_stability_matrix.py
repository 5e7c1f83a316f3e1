"""The nightly-style subset of the stability matrix: the cheapest extreme cases.

Pass criterion (solver.stability.judge): a case completes with an energy error below 1 %, or
ends ``unstable`` with a diagnosis naming the check that fired, or fails with a diagnosis that
says what to change, or is rejected up front naming the field; never a NaN, an exception or
the wall-time cap. The full matrix is ``fibrecut stability`` (docs/numerics.md).
"""

from __future__ import annotations

import pytest

from solver.fem.guard import CHECKS
from solver.stability import cases, judge, run_case

pytestmark = pytest.mark.timeout(240)

#: the matrix's cases, cheapened further for the test suite (the same extreme on a smaller body)
TINY = {"cut.length_um": 5.0, "cut.depth_um": 30.0, "tool.edge_radius_um": 5.0, "workpiece.height_um": 60.0,
        "workpiece.micro_zone_depth_um": 15.0, "numerics.n_force_samples": 20}


def _case(name: str, **extra):
    case = next(c for c in cases() if c.name == name)
    if extra:
        from dataclasses import replace

        case = replace(case, overrides={**case.overrides, **extra})
    return run_case(case)


def test_cfl_5_ends_unstable_with_a_diagnosis_naming_the_check():
    row = _case("CFL 5 (unstable by design)", **TINY)
    assert row["status"] == "unstable", row
    assert row["passed"], row.get("why_not")
    check = row["diagnosis"].split(";")[0].removeprefix("check: ")
    assert check in CHECKS.values()
    assert "numerics.cfl" in row["diagnosis"]  # tells the user what to change
    assert row["steps"] < 1000  # caught at once, not after the whole cut


def test_a_cut_beyond_max_steps_stops_with_what_to_change():
    row = _case("speed 0.01 m/s, no speed scaling (max_steps 5000)", **TINY)
    assert row["status"] == "failed" and row["passed"], row
    assert "check: max_steps" in row["diagnosis"] and "numerics.max_steps" in row["diagnosis"]
    assert row["steps"] <= 5000 + 2000  # stops within one chunk of the cap


@pytest.mark.parametrize("name, field", [("matrix nu 0.5 (rejected)", "materials.matrix.nu"),
                                         ("element size 0.1 um (rejected)", "numerics.element_size_um")])
def test_out_of_range_inputs_are_rejected_up_front_naming_the_field(name, field):
    row = _case(name)
    assert row["status"] == "rejected" and row["passed"] and field in row["diagnosis"] and "allowed" in row["diagnosis"]


@pytest.mark.parametrize("name, extra", [
    ("element size 0.5 um", {}),
    # the three cases below completed with energy errors of 1-25 % until the cohesive work was booked
    # from the nodal forces and the fragment contact moved into the compiled step (both exact now)
    ("cohesive penalty 1e+18 Pa/m", TINY),
    ("fibre angle 135 deg", TINY),
    ("edge radius 0 um", {k: v for k, v in TINY.items() if k != "tool.edge_radius_um"}),
])
def test_extreme_cases_complete_accurately_or_end_with_a_diagnosis(name, extra):
    row = _case(name, **extra)
    assert row["status"] in ("ok", "unstable", "failed"), row
    assert row["passed"], f"{name}: {row.get('why_not')} ({row['status']}, {row.get('diagnosis')})"
    if name.startswith("cohesive"):
        assert "cohesive" in (row["dt_limited_by"] or "")  # a 1e18 Pa/m penalty sets the step


def test_judge_refuses_large_energy_errors_nans_exceptions_and_hangs():
    assert judge("ok", {"energy_error": 0.005}) == (True, "")
    assert not judge("ok", {"energy_error": 0.02})[0]
    assert not judge("ok", {"energy_error": float("nan")})[0]
    assert not judge("failed", {"diagnosis": {"check": "exception", "what": "ZeroDivisionError"}})[0]
    assert not judge("failed", {"diagnosis": {"check": "max_wall_time", "what": "wall time above"}})[0]
    assert not judge("unstable", {})[0]
    assert judge("unstable", {"diagnosis": {"check": "nan", "change": "lower numerics.cfl"}})[0]


def test_energy_balance_closes_with_cohesive_failure_deletion_and_fragment_contact():
    """A shallow cut (5 um) whose chip breaks off: cohesive elements soften and fail, elements are
    deleted, fragments touch; the cohesive elements' own booking (their work against their free energy and
    dissipation) closes to 1e-3 of the work put in, and the whole balance within the stability matrix's
    tolerance. The whole balance's residual is one chaotic run's: 3e-4 and 2.7e-3 at two builds of the same
    code, the latter left by the tool's penalty contact chattering at the edge 1.16 us into the cut, before
    anything failed (per-step swings of 6e-4 J/m between kinetic and contact energy that mostly cancel)."""
    from solver.run import run
    from solver.scene import load_scene
    from solver.stability import ENERGY_TOLERANCE

    case = next(c for c in cases() if c.name == "depth 5 um")
    res = run(load_scene(case.base, case.overrides))
    m = res.metrics
    assert res.status == "ok", res.diagnosis
    assert m["n_failed_cohesive"] > 0 and m["n_failed_elements"] > 0, m  # what the balance is tested through
    external = float(res.series["energies"]["external"][-1])
    assert external > 0
    assert abs(m["cohesive_unaccounted_J_per_m"]) < 1e-3 * external, (m["cohesive_unaccounted_J_per_m"], external)
    assert m["energy_error"] < ENERGY_TOLERANCE, m["energy_error"]
