"""Benchmark of solid SPH: particle updates per second (``fibrecut bench sph``).

A square block of isotropic solid particles (epoxy-like: E = 2.96 GPa, nu = 0.4, rho = 1280, spacing
1 um, h = 1.3 dp, artificial viscosity and artificial stress on, corrected gradients) is given a
smooth velocity field (a shear plus a small expansion) and advanced by the production chunk loop.
Updates per second = active particles x steps / wall time of the compiled chunk (after a warm-up
chunk that also compiles). Threads are set with ``numba.set_num_threads``.

Each row is ``repeats`` measurements of about ``target_s / repeats`` seconds each; ``updates_per_s``
is the best of them and ``updates_per_s_median`` their median. On a shared or virtual machine
other work only ever slows a measurement down, so the best is the estimate least disturbed by it
(the convention of Python's ``timeit``); the median and the spread (``spread``: worst / best - 1)
say how disturbed the machine was.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from .bench_fem import timed_repeats
from .roofline import annotate, state_bytes

from solver.sph import loop, materials as mt, particles as pp


def _block(n: int) -> pp.Particles:
    side = max(2, int(round(math.sqrt(n))))
    dp = 1e-6
    x, y = pp.lattice(0.0, side * dp, 0.0, side * dp, dp)
    mats = mt.table(mt.isotropic(2.96e9, 0.4, 1280.0))
    prm = pp.make_params(dp)
    L = side * dp
    vx = 0.5 * np.sin(2 * math.pi * y / L)
    vy = 0.1 * np.sin(2 * math.pi * x / L)
    return pp.from_points(x, y, mats, prm, vx=vx, vy=vy)


def bench(threads: list[int] | None = None, sizes: list[int] | None = None, target_s: float = 5.0,
          repeats: int = 5, dim: int = 2) -> list[dict]:
    """One row per (size, threads): particles, steps per measurement, repeats, wall seconds (all
    measurements), CPU seconds of the process, updates_per_s (the best measurement),
    updates_per_s_median, spread, updates_per_s_per_thread (best / threads), updates_per_cpu_s
    (over all measurements: per busy core), ns_per_update (best). Module docstring.
    dim = 3: the 3D particles' workload (:mod:`solver.bench_sph3d`)."""
    if dim == 3:
        from .bench_sph3d import bench as bench3d

        kw = {"threads": threads or [1, 2], "sizes": sizes or [10_000, 100_000], "target_s": target_s}
        return bench3d(**kw)
    if dim != 2:
        raise ValueError(f"dim = {dim}: allowed 2 or 3")
    threads = threads or [1, 2]
    sizes = sizes or [10_000, 100_000]
    rows = []
    max_threads = numba.config.NUMBA_NUM_THREADS
    for n in sizes:
        for th in threads:
            if th > max_threads:
                rows.append({"size": n, "threads": th, "error": f"only {max_threads} numba threads available"})
                continue
            numba.set_num_threads(th)
            P = _block(n)
            dt = loop.stable_dt(P)
            loop.step_chunk(P, 2, dt, threads=th)  # compile and warm up
            steps = 3
            t = time.perf_counter()
            loop.step_chunk(P, steps, dt, threads=th)
            el = time.perf_counter() - t
            per_step = el / steps
            steps = max(3, int(target_s / repeats / max(per_step, 1e-9)))
            rates, wall, cpu, status = timed_repeats(lambda s: loop.step_chunk(P, s, dt, threads=th), P.n_act, steps,
                                                     repeats)
            best = max(rates)
            rows.append(annotate({"size": P.n_act, "threads": th, "steps": steps, "repeats": len(rates), "seconds": round(wall, 3),
                                  "cpu_seconds": round(cpu, 3), "updates_per_s": best,
                                  "updates_per_s_median": float(np.median(rates)), "spread": best / min(rates) - 1.0,
                                  "updates_per_s_per_thread": best / th,
                                  "updates_per_cpu_s": P.n_act * steps * len(rates) / max(cpu, 1e-9),
                                  "ns_per_update": 1e9 / best, "status": status},
                                 "updates_per_s", state_bytes(P, P.n_act), th))
    numba.set_num_threads(max_threads)
    return rows


if __name__ == "__main__":  # pragma: no cover
    import json
    import sys

    sizes = [int(a) for a in sys.argv[1:]] or None
    for r in bench([1, 2], sizes):
        print(json.dumps(r))
