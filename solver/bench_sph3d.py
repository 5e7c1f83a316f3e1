"""Benchmark of 3D solid SPH (``fibrecut bench sph --dim 3``): particle updates per second.

The workload: a cube of isotropic solid particles (epoxy-like: E = 2.96 GPa, nu = 0.4, rho = 1280,
cubic lattice of spacing 1 um, h = 1.3 dp, artificial viscosity and artificial stress on, corrected
gradients) given a smooth velocity field (three shears), advanced by the production chunk loop
(:func:`solver.sph3d.loop.step_chunk`) at the signal-speed step. Each row times the compiled chunk
after a warm-up chunk that also compiles:

    updates_per_s      = particles x steps / wall seconds      (best of ``repeats`` measurements)
    updates_per_cpu_s  = particles x steps / process CPU seconds (all measurements; per busy core)

On a shared machine other work only slows a measurement down: the best wall figure and the CPU
figure say what one core delivers, the median and the spread how disturbed the machine was.
``cost_vs_smallest`` is the CPU time per particle update against the smallest size's at the same
thread count (1.0: cost linear in N) and ``loglog_slope`` the slope of log(CPU time per step) against
log(N) between the smallest and this size (1.0: linear; None on the smallest size's rows).
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from .roofline import annotate, state_bytes

from .bench_fem import check_threads, stamp_machine, timed_repeats


def _block(n: int):
    from solver.sph import materials as mt
    from solver.sph3d import particles as pp

    side = max(3, int(round(n ** (1 / 3))))
    dp = 1e-6
    L = side * dp
    x = pp.lattice3((0.0, 0.0, 0.0), (L, L, L), dp)
    mats = mt.table(mt.isotropic(2.96e9, 0.4, 1280.0))
    v = np.vstack([0.5 * np.sin(2 * math.pi * x[1] / L), 0.1 * np.sin(2 * math.pi * x[2] / L),
                   0.1 * np.sin(2 * math.pi * x[0] / L)])
    return pp.from_points(x, mats, pp.make_params(dp), v=v)


def bench(threads=(1, 2), sizes=(10_000, 100_000), target_s: float = 5.0, repeats: int = 3) -> list[dict]:
    """One row per (size, threads): particle updates per second (best and median of the wall-clock
    measurements, per CPU second), cost per update against the smallest size, the log-log slope."""
    from solver.sph3d import loop

    rows = []
    base: dict[int, tuple[int, float]] = {}
    old = numba.get_num_threads()
    try:
        for n in sizes:
            P = _block(int(n))
            dt = loop.stable_dt(P)
            loop.step_chunk(P, 2, dt)  # compile and warm up
            for th in threads:
                th = int(th)
                check_threads(th)
                numba.set_num_threads(th)
                t = time.perf_counter()
                loop.step_chunk(P, 2, dt, threads=th)
                per_step = (time.perf_counter() - t) / 2
                steps = max(2, int(target_s / max(1, repeats) / max(per_step, 1e-9)))
                rates, wall, cpu, status = timed_repeats(lambda s: loop.step_chunk(P, s, dt, threads=th), P.n, steps,
                                                         repeats)
                best = max(rates)
                done = P.n * steps * len(rates)
                cpu_ns = 1e9 * cpu / done
                base.setdefault(th, (P.n, cpu_ns))
                n0, ns0 = base[th]
                slope = (math.log((cpu_ns * P.n) / (ns0 * n0)) / math.log(P.n / n0)) if P.n != n0 else None
                rows.append(annotate({"dim": 3, "size": P.n, "threads": th, "steps": steps, "repeats": len(rates),
                                      "wall_s": round(wall, 3), "cpu_s": round(cpu, 3), "updates_per_s": best,
                                      "updates_per_s_median": float(np.median(rates)), "spread": best / min(rates) - 1.0,
                                      "updates_per_cpu_s": done / max(cpu, 1e-9), "ns_per_update": 1e9 / best,
                                      "cost_vs_smallest": cpu_ns / ns0, "loglog_slope": slope, "status": status},
                                     "updates_per_s", state_bytes(P, P.n), th))
            del P
    finally:
        numba.set_num_threads(old)
    return stamp_machine(rows)


if __name__ == "__main__":  # python -m solver.bench_sph3d [sizes...]
    import json
    import sys

    print(json.dumps(bench([1], [int(float(s)) for s in sys.argv[1:]] or [10_000]), indent=1))
