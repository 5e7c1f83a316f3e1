"""Trends every orthogonal-cutting experiment on UD CFRP shows, on the quick scenes.

A cut with fracture is chaotic: one run is one sample. The margins asserted here are the ones the
replicated means resolve by far (docs/validation.md, the quick table: 4 replicas each, every replica of one level
beyond every replica of the other), so a single run per level tells them apart; what the replicas do not
resolve (the rake angle's effect on classic FEM's Fc, the hybrid's 15-degree steps) is not asserted.

The cuts here run at speed scaling 1000, four times the quick scenes' default (250, where their forces level
off), for the suite's time: the trends are the same at both (docs/validation.md has them at 250, docs/validation-details.md at 1000; the replicated
margins quoted below are the rows ``*-ss1000`` of scripts/validation.py).
"""

import multiprocessing
import os
from unittest import mock
from concurrent.futures import ProcessPoolExecutor

import pytest

from solver import load_scene, run

#: the test's speed scaling (see above)
SPEED_SCALING = 1000.0
QUICK = {"numerics.n_frames": 0, "numerics.n_force_samples": 200, "numerics.speed_scaling": SPEED_SCALING}


def _fc(scene, **ov):
    r = run(load_scene(scene, {**QUICK, **{k.replace("__", "."): v for k, v in ov.items()}}))
    assert r.status == "ok", r.summary()
    return r.metrics["cutting_force_N_per_mm"]


def _fc_at_once(*runs, workers=None):
    """Fc of several runs (scene, overrides) at once, one process each (at most ``workers``), each process on one
    numba thread, so that two of them share a 2-core machine in the time of one (spawned, not forked: numba's
    threads do not survive a fork; the spawned processes read NUMBA_NUM_THREADS when they import numba)."""
    with mock.patch.dict(os.environ, {"NUMBA_NUM_THREADS": "1"}), \
            ProcessPoolExecutor(max_workers=workers or len(runs), mp_context=multiprocessing.get_context("spawn")) as pool:
        return [f.result() for f in [pool.submit(_fc, scene, **ov) for scene, ov in runs]]


@pytest.fixture(scope="module")
def fc_0deg_50um():
    return _fc("seed-0deg-fem-quick", cut__depth_um=50.0)


def test_cutting_force_grows_with_depth_of_cut(fc_0deg_50um):
    """0 deg, rake 30: from 50 to 100 um the steady Fc more than doubles (replicated, rows quick-0-depth50-ss1000
    and quick-0-ss1000: 8.56 +- 0.33 (n = 4) against 20.85 +- 0.48 N/mm (n = 8); the lowest replica at 100 um,
    18.9, is 2.0 times the highest at 50 um, 9.5)."""
    assert _fc("seed-0deg-fem-quick") > 1.5 * fc_0deg_50um > 0


def test_cutting_force_at_90_degrees_exceeds_that_at_0(fc_0deg_50um):
    """Same tool (rake 30) and depth (50 um): fibres across the cut take more force to cut than fibres along it
    (replicated, rows quick-90-rake30-ss1000 and quick-0-depth50-ss1000: 11.16 +- 0.14 against 8.56 +- 0.33 N/mm,
    n = 4 each; the lowest replica at 90 deg, 11.0, is 1.16 times the highest at 0 deg, 9.5)."""
    assert _fc("seed-90deg-fem-quick", tool__rake_angle_deg=30.0) > fc_0deg_50um


def test_cutting_force_falls_as_the_rake_rises_when_the_crushed_material_stays():
    """The hybrid (D 0.1), 0 deg, depth 100 um: the material the edge crushes stays as particles, piles up ahead
    of a rake face normal to the cut and rides up a face leaning back, so Fc falls from rake 0 to rake 30
    (docs/validation.md). Whether the pile forms varies from replica to replica: the rake-0 forces spread
    widely (a replica now and then at the rake-30 level), so the levels are compared by their means over four
    replicas each (the speed perturbation of ``fibrecut convergence --replicas``). On the 30-um cut run here
    (``scripts/replicas.py seed-0deg-hybrid-d01-quick 12 cut.length_um=30 numerics.n_force_samples=400
    numerics.speed_scaling=1000 [tool.rake_angle_deg=0]``, one thread, 12 replicas each): 42.5 +- 2.5 N/mm
    (sd 8.8, 26.8-58.8) against 26.0 +- 0.3 (sd 1.0, 24.5-27.6); with these spreads a four-replica mean at
    rake 0 falls below one at rake 30 with a probability of about 1e-4 (normal approximation, difference
    16.5 N/mm over its standard error 4.4). Over the whole quick cut at speed scaling 250 the two levels are
    not told apart (docs/validation.md): on this first stretch of the cut the pile ahead of a rake-0 face has
    formed and the chip on a rake-30 face is still short."""
    import numpy as np

    from solver.convergence import replica_speed_scalings

    base = SPEED_SCALING
    short = {"cut__length_um": 30.0, "numerics__n_force_samples": 400}
    runs = [("seed-0deg-hybrid-d01-quick", {"tool__rake_angle_deg": rake, "numerics__speed_scaling": ss, **short})
            for rake in (0.0, 30.0) for ss in replica_speed_scalings(base, 4)]
    fc0, fc30 = np.array(_fc_at_once(*runs, workers=2)).reshape(2, 4)
    assert fc0.mean() > fc30.mean() and fc30.min() > 0, (fc0, fc30)
