"""The number of threads a run's chunks take (solver.threads): chosen by timing, and without effect on results."""

import copy
from importlib import import_module

import numba
import numpy as np
import pytest

from solver.threads import ThreadChoice


def _choice(**kw):
    c = ThreadChoice(candidates=(1, 2), **kw)
    if c.candidates != [1, 2]:
        pytest.skip("needs two numba threads (NUMBA_NUM_THREADS=1 here)")
    return c


def _run(c, cost, n):
    """n chunks of 100 steps whose seconds per step on t threads are cost[t]; the threads each ran on."""
    used = []
    for _ in range(n):
        t = c.next()
        used.append(t)
        c.record(t, cost[t] * 100, 100)
    return used


def test_the_faster_count_is_held_after_one_probe_of_each():
    c = _choice(hold=4, hold_max=16)
    used = _run(c, {1: 1.0, 2: 1.1}, 3)
    assert used == [1, 1, 2]  # warm-up on one thread, then one probe of each
    assert c.best == 1 and c.seconds_per_step == {1: 1.0, 2: 1.1}
    assert _run(c, {1: 1.0, 2: 1.1}, 4) == [1] * 4  # held for ``hold`` chunks, then probed again


def test_a_winner_that_stays_is_probed_ever_more_rarely_and_a_change_is_followed():
    c = _choice(hold=2, hold_max=8)
    used = _run(c, {1: 1.0, 2: 1.1}, 60)
    probes_of_2 = [i for i, t in enumerate(used) if t == 2]
    gaps = np.diff(probes_of_2)
    assert gaps[-1] > gaps[0] and max(gaps) <= 8 + 2  # the hold doubled up to its cap
    assert c.switches == 0  # one thread, the warm-up's, stayed the faster
    used = _run(c, {1: 1.1, 2: 1.0}, 20)  # the machine changed (a replica beside it ended)
    assert c.best == 2 and c.switches == 1 and used[-10:].count(2) >= 7


def test_probing_a_much_slower_count_costs_at_most_the_overhead():
    """Two threads twenty times slower (a core shared with another run): the probes of it cost at most
    OVERHEAD of the time the chunks took."""
    from solver.threads import OVERHEAD

    cost = {1: 1.0, 2: 20.0}
    c = _choice(hold=2, hold_max=8)
    used = _run(c, cost, 2000)[3:]  # after the warm-up and the first probes
    spent = sum(cost[t] for t in used)
    assert (spent - len(used) * cost[1]) / spent < OVERHEAD


def test_a_count_within_the_noise_does_not_replace_the_one_held():
    c = _choice(hold=2)
    _run(c, {1: 1.0, 2: 0.97}, 3)
    assert c.best == 1 and c.switches == 0
    _run(c, {1: 1.0, 2: 0.9}, 10)  # beyond the noise: it does
    assert c.best == 2 and c.switches == 1


def test_one_long_call_runs_on_one_thread():
    """A state advanced in one call (no chunks to time) runs on the warm-up's single thread: on a core shared
    with other processes, two threads stepping a small problem wait on each other at every parallel loop."""
    c = _choice()
    assert c.next() == 1


def test_a_chunk_that_ran_no_step_is_not_a_measurement():
    c = _choice(warmup=0)
    c.record(1, 5.0, 0)
    assert c.next() == 1 and 1 not in c.seconds_per_step


def test_one_candidate_is_never_probed():
    c = ThreadChoice(candidates=(1,))
    assert _run(c, {1: 1.0}, 10) == [1] * 10 and c.probes == 0


def test_a_cut_steps_the_same_on_one_and_on_two_threads():
    """The choice is free only if it cannot change a result: the quick 0-degree scene's FEM state, cut
    into and with elements failing, advanced the same steps on one and on two threads, bit for bit."""
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs two numba threads (NUMBA_NUM_THREADS=1 here)")
    from solver.engine import build_engine
    from solver.fem import loop as fl
    from solver.run import FIDELITIES
    from solver.scene import load_scene
    from solver.tool import tool_array

    scene = load_scene("seed-0deg-fem-quick", {"numerics.speed_scaling": 1000.0})  # elements fail within 4000 steps
    si = scene.si()
    module, name = FIDELITIES[scene.fidelity].mesher.split(":")
    mesh = getattr(import_module(module), name)(si)
    eng = build_engine(scene, si, mesh, tool_array(si))
    s = eng.state
    assert fl.advance(s, 4000, None, k_pen=eng.k_tool, mu=eng.mu, threads=1).status == "ok"
    a, b = copy.deepcopy(s), copy.deepcopy(s)
    assert fl.advance(a, 800, None, k_pen=eng.k_tool, mu=eng.mu, threads=1).status == "ok"
    assert fl.advance(b, 800, None, k_pen=eng.k_tool, mu=eng.mu, threads=2).status == "ok"
    assert (s.alive == 0).any() or (s.dmg > 0).any()  # fracture under way
    for k in ("x", "y", "vx", "vy", "alive", "dmg", "en"):
        assert np.array_equal(getattr(a, k), getattr(b, k)), k
