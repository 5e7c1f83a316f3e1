"""Benchmark of the analytic fidelity (``fibrecut bench analytic``): the cost of one call.

The analytic model (:mod:`solver.analytic`) answers in well under a millisecond, which is what lets the
service evaluate it inline and optuna search it by thousands of trials. This measures the time per
``run_analytic`` call on the paper's 0-degree scene at fibre angles 0, 45 and 90 degrees, ``sizes`` calls
each (best of 5 repeats; pure Python, one thread whatever ``threads`` says).
"""

from __future__ import annotations

import time

ANGLES = (0.0, 45.0, 90.0)


def bench(threads: list[int] | None = None, sizes: list[int] | None = None) -> list[dict]:
    from .analytic import run_analytic
    from .scene import load_scene

    rows = []
    for n in sizes or [1000]:
        for angle in ANGLES:
            s = load_scene("seed-0deg-fem", {"fidelity": "analytic", "workpiece.fibre_angle_deg": angle})
            run_analytic(s)
            best = float("inf")
            for _ in range(5):
                t0 = time.perf_counter()
                for _ in range(n):
                    run_analytic(s)
                best = min(best, (time.perf_counter() - t0) / n)
            rows.append({"calls": n, "fibre_angle_deg": angle, "threads": 1, "us_per_call": best * 1e6,
                         "calls_per_s": 1.0 / best})
    return rows
