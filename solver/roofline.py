"""The memory roofline of a benchmark row: how fast an engine could update its items if memory were the limit.

An explicit step streams its state: every element (or particle) reads its nodes and its own arrays and
writes back what changes. When the state does not fit in cache, the step cannot beat

    roofline_updates_per_s = bandwidth / bytes_per_update

(Williams, Waterman & Patterson, "Roofline: an insightful visual performance model for multicore
architectures", Commun. ACM 52 (2009) 65). ``bytes_per_update`` here is the engine state's bytes per
element or particle (every array of the state once per step: a lower bound on the traffic, since written
arrays move twice and gathered node data may move more than once), and ``bandwidth`` is measured on the
spot with the STREAM triad a = b + s c (McCalpin, "Memory bandwidth and machine balance in current high
performance computers", IEEE TCCA Newsletter, 1995) on arrays far larger than the caches, counting 24
bytes per index (two reads, one write; the write-allocate read is not counted, as STREAM does not).
A row's ``roofline_fraction`` = measured rate / roofline: near 1 the step is memory bound; far below, it is
bound by latency, gathers or arithmetic.
"""

from __future__ import annotations

import time

import numba
import numpy as np
from numba import prange

_CACHE: dict[tuple[int, int], float] = {}


@numba.njit(parallel=True, cache=True)
def _triad(a, b, c, s):
    for i in prange(a.shape[0]):
        a[i] = b[i] + s * c[i]


def stream_bandwidth(threads: int = 1, n: int = 1 << 24, repeats: int = 5) -> float:
    """The STREAM triad's bandwidth [bytes/s] with ``threads`` numba threads: the best of ``repeats`` passes
    over three arrays of ``n`` doubles (3 x 128 MB by default). Measured once per thread count and process."""
    key = (int(threads), int(n))
    if key in _CACHE:
        return _CACHE[key]
    old = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        a, b, c = np.zeros(n), np.ones(n), np.full(n, 2.0)
        _triad(a, b, c, 3.0)  # compile, touch the pages
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            _triad(a, b, c, 3.0)
            best = min(best, time.perf_counter() - t0)
    finally:
        numba.set_num_threads(old)
    _CACHE[key] = 24.0 * n / best
    return _CACHE[key]


def state_bytes(state, n_items: int) -> float:
    """Bytes of a state's numpy arrays per element or particle (module docstring's ``bytes_per_update``)."""
    total = sum(v.nbytes for v in vars(state).values() if isinstance(v, np.ndarray))
    return total / max(int(n_items), 1)


def annotate(row: dict, rate_key: str, bytes_per_update: float, threads: int) -> dict:
    """Add the roofline columns to a benchmark row whose measured rate is ``row[rate_key]`` [updates/s]."""
    bw = stream_bandwidth(threads)
    roof = bw / bytes_per_update
    row["bytes_per_update"] = round(bytes_per_update, 1)
    row["bandwidth_GB_s"] = round(bw / 1e9, 2)
    row["roofline_updates_per_s"] = roof
    row["roofline_fraction"] = row[rate_key] / roof
    return row
