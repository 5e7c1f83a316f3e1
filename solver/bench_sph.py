"""Benchmark of solid SPH: particle updates per second (``fibrecut bench sph``).

A square block of isotropic solid particles (epoxy-like: E = 2.96 GPa, nu = 0.4, rho = 1280, spacing
1 um, h = 1.3 dp, artificial viscosity and artificial stress on, corrected gradients) is given a
smooth velocity field (a shear plus a small expansion) and advanced by the production chunk loop.
Updates per second = active particles x steps / wall time of the compiled chunk (after a warm-up
chunk that also compiles). Threads are set with ``numba.set_num_threads``.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

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


def bench(threads: list[int] | None = None, sizes: list[int] | None = None, target_s: float = 3.0) -> list[dict]:
    """One row per (size, threads): particles, steps, wall seconds, CPU seconds of the process,
    updates_per_s (wall), updates_per_s_per_thread, updates_per_cpu_s (per busy core: the honest figure on
    a shared machine, where the wall clock includes time the cores spent on other processes),
    ns_per_update. Each measurement runs at least ``target_s`` seconds (at least 3 steps)."""
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
            loop.step_chunk(P, 2, dt)  # compile and warm up
            steps = 3
            t = time.perf_counter()
            loop.step_chunk(P, steps, dt)
            el = time.perf_counter() - t
            per_step = el / steps
            steps = max(3, int(target_s / max(per_step, 1e-9)))
            t = time.perf_counter()
            c = time.process_time()
            rep = loop.step_chunk(P, steps, dt)
            el = time.perf_counter() - t
            cpu = time.process_time() - c
            ups = P.n_act * rep.steps / el
            rows.append({"size": P.n_act, "threads": th, "steps": rep.steps, "seconds": round(el, 3),
                         "cpu_seconds": round(cpu, 3), "updates_per_s": ups, "updates_per_s_per_thread": ups / th,
                         "updates_per_cpu_s": P.n_act * rep.steps / max(cpu, 1e-9),
                         "ns_per_update": 1e9 / ups, "status": rep.status})
    numba.set_num_threads(max_threads)
    return rows


if __name__ == "__main__":  # pragma: no cover
    import json
    import sys

    sizes = [int(a) for a in sys.argv[1:]] or None
    for r in bench([1, 2], sizes):
        print(json.dumps(r))
