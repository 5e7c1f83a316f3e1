"""Benchmark of the FEM engine (``fibrecut bench fem``): element updates per second.

The workload is the cutting scene's micro-zone mix: fibre strips (3 elements across) and matrix
strips (1 element across) along x with a cohesive element on every fibre-matrix interface
(:func:`solver.fem.gridmesh.strip_mesh`), set vibrating (a bending + stretching velocity field),
no tool. Each row times the compiled chunk after a warm-up (compilation excluded):

    element_updates_per_s      = elements x steps / wall seconds
    element_updates_per_cpu_s  = elements x steps / process CPU seconds (all threads)

On a shared machine the wall figure is noisy; the CPU figure says what one core delivers. Each row also
gets its memory roofline (:mod:`solver.roofline`: the state's bytes per element, the STREAM triad's
bandwidth measured on the spot with the row's threads, and the fraction of the roofline reached).
``threads`` runs the compiled chunk with numba.set_num_threads(t); ``speedup`` is against the
1-thread row of the same size.
"""

from __future__ import annotations

import math
import os
import time

import numba
import numpy as np

from .roofline import annotate, state_bytes


def _state(n_elems: int):
    from solver import fem
    from solver.fem.gridmesh import strip_mesh
    from solver.scene import Scene

    si = Scene().si()
    per_column = 4  # one matrix element + three fibre elements per fibre pitch
    n_fibres = max(1, int(round(math.sqrt(n_elems / per_column) / 4)))
    nx = max(1, int(round(n_elems / (per_column * n_fibres))))
    h = 2e-6
    mesh = strip_mesh(nx, n_fibres, nx * h, 7.5e-6, 5e-6, across_fibre=3, across_matrix=1)
    mesh.fixed_x[mesh.x < 1e-12] = True
    mesh.fixed_y[mesh.x < 1e-12] = True
    state = fem.build_state(mesh, si)
    length = nx * h
    state.vx[:] = 0.5 * state.X0 / length
    state.vy[:] = 0.5 * np.sin(np.pi * state.X0 / length)
    return state


def check_threads(t: int) -> None:
    """A benchmark's thread count: 1 to the numba threads available."""
    if t < 1 or t > numba.config.NUMBA_NUM_THREADS:
        raise ValueError(f"threads = {t}: allowed 1 to {numba.config.NUMBA_NUM_THREADS} (numba threads available)")


def timed_repeats(step, n: int, steps: int, repeats: int) -> tuple[list[float], float, float, str]:
    """``repeats`` timed runs of ``step(steps)`` (a chunk of steps returning a report with ``steps`` and
    ``status``) over n updated items: the rates n x steps / wall of each run, the total wall and CPU seconds and
    the status (a run that ends unstable ends the series)."""
    rates, wall, cpu, status = [], 0.0, 0.0, "ok"
    for _ in range(max(1, repeats)):
        w0, c0 = time.perf_counter(), time.process_time()
        rep = step(steps)
        el = time.perf_counter() - w0
        cpu += time.process_time() - c0
        wall += el
        rates.append(n * rep.steps / el)
        if rep.status != "ok":
            status = rep.status
            break
    return rates, wall, cpu, status


def add_row(rows: list[dict], row: dict, base: float | None, state, ne: int) -> float | None:
    """Append an element-update row with its speedup over the 1-thread rate ``base`` (the row's own rate when it
    is the 1-thread row) and its roofline figures (:func:`solver.roofline.annotate`); returns the 1-thread rate."""
    rate, t = row["element_updates_per_s"], row["threads"]
    if t == 1:
        base = rate
    row["speedup_vs_1_thread"] = rate / base if base else float("nan")
    rows.append(annotate(row, "element_updates_per_s", state_bytes(state, ne), t))
    return base


def stamp_machine(rows: list[dict]) -> list[dict]:
    """The rows with the machine's 1-minute load and core count, measured once after the runs."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    for r in rows:
        r["load_average_1min"] = load
        r["cpu_count"] = os.cpu_count()
    return rows


def sweep(sizes, threads, build, elements, timed_row) -> list[dict]:
    """An element-update benchmark's rows: for each size n the state ``build(n)`` of ne = ``elements(state)``
    elements, timed over about 3e7 element updates (5 to 2000 steps) at each thread count t by
    ``timed_row(state, ne, steps, t)``, which returns the row; each row with its speedup and roofline
    (:func:`add_row`), all with the machine's load (:func:`stamp_machine`)."""
    rows = []
    for n in sizes:
        state = build(int(n))
        ne = elements(state)
        steps = int(max(5, min(2000, 3e7 / ne)))
        base = None
        for t in threads:
            t = int(t)
            check_threads(t)
            base = add_row(rows, timed_row(state, ne, steps, t), base, state, ne)
        del state
    return stamp_machine(rows)


def _time(state, steps: int, threads: int):
    from solver.fem import loop

    old = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        loop._call_chunk(state, 2, 0.0, math.inf, 0.0, 0.0)  # warm-up (compiles once)
        w0, c0 = time.perf_counter(), time.process_time()
        done = loop._call_chunk(state, steps, 0.0, math.inf, 0.0, 0.0)
        w1, c1 = time.perf_counter(), time.process_time()
    finally:
        numba.set_num_threads(old)
    return done, w1 - w0, c1 - c0


def bench(threads: list[int] = (1, 2), sizes: list[int] = (10_000, 100_000, 1_000_000), dim: int = 2) -> list[dict]:
    """One row per (size, threads): element updates per second (wall and CPU), the speedup.

    threads: e.g. [1, 2]; sizes: element counts, e.g. [1e4, 1e5, 1e6]; dim: 2 (this module's plane-strain
    workload) or 3 (hexahedra: :mod:`solver.bench_fem3d`).
    """
    if dim == 3:
        from .bench_fem3d import bench as bench3d

        return bench3d(threads, sizes)
    if dim != 2:
        raise ValueError(f"dim = {dim}: allowed 2 or 3")

    def timed_row(state, ne: int, steps: int, t: int) -> dict:
        done, wall, cpu = _time(state, steps, t)
        rate = ne * done / wall
        return {"elements": ne, "cohesive": state.coh.shape[0], "threads": t, "steps": done, "wall_s": round(wall, 4),
                "element_updates_per_s": rate, "element_updates_per_cpu_s": ne * done / max(cpu, 1e-9),
                "ns_per_element_update": 1e9 * wall / (ne * done), "status": "ok" if state.guard[0] == 0 else "unstable"}

    return sweep(sizes, threads, _state, lambda state: state.quads.shape[0], timed_row)


if __name__ == "__main__":  # python -m solver.bench_fem
    import json
    import sys

    sizes = [int(float(s)) for s in sys.argv[1:]] or [10_000, 100_000]
    print(json.dumps(bench([1, 2], sizes), indent=1))
