"""Trends every orthogonal-cutting experiment on UD CFRP shows, on the quick scene (classic FEM).

A cut with fracture is chaotic: one run is one sample. The margins asserted here are the ones the
replicated means resolve by far (docs/validation.md, "Trends": 4 replicas each, every replica of one level
beyond every replica of the other), so a single run per level tells them apart; what the replicas do not
resolve (the rake angle's effect on Fc) is not asserted.
"""

import pytest

from solver import load_scene, run

QUICK = {"numerics.n_frames": 0, "numerics.n_force_samples": 200}


def _fc(scene, **ov):
    r = run(load_scene(scene, {**QUICK, **{k.replace("__", "."): v for k, v in ov.items()}}))
    assert r.status == "ok", r.summary()
    return r.metrics["cutting_force_N_per_mm"]


@pytest.fixture(scope="module")
def fc_0deg_50um():
    return _fc("seed-0deg-fem-quick", cut__depth_um=50.0)


def test_cutting_force_grows_with_depth_of_cut(fc_0deg_50um):
    """0 deg, rake 30: from 50 to 100 um the steady Fc triples (replicated: 6.1 +- 1.0 against 18.4 +- 1.1 N/mm;
    the lowest replica at 100 um, 15.6, is 1.9 times the highest at 50 um, 8.2)."""
    assert _fc("seed-0deg-fem-quick") > 1.5 * fc_0deg_50um > 0


def test_cutting_force_at_90_degrees_exceeds_that_at_0(fc_0deg_50um):
    """Same tool (rake 30) and depth (50 um): fibres across the cut take more force to cut than fibres along it
    (replicated: 10.5 +- 0.3 against 6.1 +- 1.0 N/mm; the lowest replica at 90 deg, 10.0, is 1.23 times the highest
    at 0 deg, 8.2)."""
    assert _fc("seed-90deg-fem-quick", tool__rake_angle_deg=30.0) > 1.15 * fc_0deg_50um
