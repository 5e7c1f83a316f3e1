"""How many threads a run's compiled chunks take: decided by timing the chunks themselves.

The engines' compiled chunks are parallel loops whose results do not depend on the number of threads
(each block writes only its own rows and every sum is taken in a fixed order; ``tests/test_threads.py``
runs a cut's steps on one and on two threads and compares the states bit for bit), so the number of
threads is a matter of speed only. Which is faster depends on the problem's size and on what else the
machine runs: waking a second thread costs a few microseconds per parallel loop, a small scene's step
has a dozen of them, and a core busy with another run makes the thread that waits on it the slowest.
A fixed size threshold cannot know the second part; a measurement can.

:class:`ThreadChoice` times each chunk per step. The warm-up call (which may load compiled code) runs on one
thread, so a caller that advances a state in one long call (a test, a verification case) never meets the
worst case: on a core shared with another process two threads can be a hundred times slower than one on a
small problem (a two-element cohesive test: 377 s against a few seconds, with three other runs on the machine),
while one thread is at most the thread count times slower than the best. After it the choice
runs one probe chunk on each candidate, then holds the fastest for ``hold`` chunks and probes again,
doubling ``hold`` (up to ``hold_max``) each time the same candidate wins and starting again from the
shortest hold when another wins, so a run that stays on one answer probes rarely and one whose
answer changes (particles appear, a replica beside it starts or ends) follows it. A probe of a
candidate r times slower than the winner costs r - 1 chunks: the hold is at least (r - 1) / OVERHEAD
chunks, so probing costs at most OVERHEAD of the run (on a core shared with another run two threads
can be twenty times slower than one). A candidate within MARGIN of the one held does not replace it
(timing noise).
"""

from __future__ import annotations

import math
import time

import numba


def available() -> int:
    """The most threads numba may use in this process (NUMBA_NUM_THREADS)."""
    return int(numba.config.NUMBA_NUM_THREADS)


#: the largest share of a run's time the probes of slower candidates may cost
OVERHEAD = 0.05
#: a candidate must be this much faster than the one held to replace it
MARGIN = 0.05


def run_on(threads: int, call):
    """``call()`` on ``threads`` numba threads (clamped to 1 .. :func:`available`), the count restored after."""
    old = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(threads), available())))
    try:
        return call()
    finally:
        numba.set_num_threads(old)


class ThreadChoice:
    """The number of threads for the next chunk, from timing the chunks run so far (module docstring)."""

    def __init__(self, candidates: tuple[int, ...] | None = None, hold: int = 16, hold_max: int = 256,
                 warmup: int = 1):
        nmax = available()
        cands = candidates if candidates is not None else (1, nmax)
        self.candidates = sorted({int(c) for c in cands if 1 <= int(c) <= nmax}) or [1]
        self.hold_min, self.hold_max = int(hold), int(hold_max)
        self.hold = self.hold_min
        self.warmup = int(warmup)
        self.best = self.candidates[0]  # the warm-up's: one thread (module docstring)
        self.seconds_per_step: dict[int, float] = {}
        self._probe: list[int] = list(self.candidates) if len(self.candidates) > 1 else []
        self._held = 0
        self.calls = 0  # chunks recorded
        self.probes = 0  # chunks run as probes
        self.switches = 0  # times the winner changed

    def next(self) -> int:
        """The threads to run the next chunk on."""
        if self.warmup > 0 or not self._probe:
            return self.best
        return self._probe[0]

    def record(self, threads: int, seconds: float, steps: int) -> None:
        """The chunk just run on ``threads`` took ``seconds`` for ``steps`` steps."""
        self.calls += 1
        if self.warmup > 0:
            self.warmup -= 1
            return
        if len(self.candidates) == 1:
            return
        if self._probe and threads == self._probe[0]:
            if steps <= 0:
                return  # nothing to time: probe again
            self.seconds_per_step[threads] = seconds / steps
            self._probe.pop(0)
            self.probes += 1
            if not self._probe:
                t = self.seconds_per_step
                winner = min(self.candidates, key=lambda c: t.get(c, float("inf")))
                if winner != self.best and t.get(self.best, float("inf")) <= (1.0 + MARGIN) * t[winner]:
                    winner = self.best  # within the noise: keep it
                if winner == self.best:
                    self.hold = min(2 * self.hold, self.hold_max)
                else:
                    self.best = winner
                    self.hold = self.hold_min
                    self.switches += 1
                slowest = max(t.get(c, 0.0) for c in self.candidates) / max(t[winner], 1e-300)
                self.hold = max(self.hold, int(math.ceil((slowest - 1.0) / OVERHEAD)))
                self._held = 0
            return
        if not self._probe:
            self._held += 1
            if self._held >= self.hold:
                self._probe = list(self.candidates)

    def run(self, call, steps_of=lambda result: result):
        """``call()`` on the chosen number of threads, timed and recorded; returns its result
        (``steps_of(result)``: the steps it ran)."""
        threads = self.next()
        t0 = time.perf_counter()
        result = run_on(threads, call)
        self.record(threads, time.perf_counter() - t0, int(steps_of(result)))
        return result

    def summary(self) -> dict:
        """What the choice measured (for a run's metrics)."""
        return {"threads": self.best, "candidates": list(self.candidates), "calls": self.calls, "probes": self.probes,
                "switches": self.switches,
                "seconds_per_step": {str(k): v for k, v in sorted(self.seconds_per_step.items())}}
