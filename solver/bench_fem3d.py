"""Benchmark of the 3D hexahedral engine (``fibrecut bench fem --dim 3``): hexahedron updates per second.

The workload: a box of nx x ny x nz hexahedra (about 4:1:1, :func:`solver.fem3d.gridmesh3d.box_mesh`,
slightly distorted) of the scene's transversely isotropic fibre pointing obliquely (30 deg in x-y,
20 deg out of it: the full 6x6 stiffness), one end clamped, set vibrating (a bending + stretching
velocity field), at the stable step. Each row times the compiled chunk (elements, gather, update:
:func:`solver.fem3d.loop.advance`) after a warm-up (compilation excluded):

    element_updates_per_s      = elements x steps / wall seconds
    element_updates_per_cpu_s  = elements x steps / process CPU seconds (all threads)

On a shared machine the wall figure is noisy; the CPU figure says what one core delivers.
``ns_per_element_update`` is wall time per element and step; ``cost_vs_smallest`` compares it with the
smallest size's at the same thread count (1.0 = cost linear in the number of elements).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .bench_fem import sweep


def _state(n_elems: int):
    from solver.fem3d import gridmesh3d, loop, material3d
    from solver.verification.fem3d_cases import fibre_data

    m = max(1, int(round((n_elems / 16) ** (1 / 3))))
    ny = nz = m
    nx = max(1, int(round(n_elems / (ny * nz))))
    h = 1e-5
    mesh = gridmesh3d.box_mesh(nx, ny, nz, nx * h, ny * h, nz * h, perturb=0.1)
    E1, E2, G12, nu12, nu23, rho = fibre_data()
    C = material3d.fibre_stiffness(E1, E2, G12, nu12, nu23, material3d.fibre_direction(math.radians(30), math.radians(20)))
    s = loop.build_state(mesh.X, mesh.hexes, [C], [rho], cfl=0.9)
    s.fix[:, mesh.X[0] < 1e-12] = 1
    length = nx * h
    s.v[0] = 0.5 * s.X0[0] / length
    s.v[2] = 0.5 * np.sin(np.pi * s.X0[0] / length)
    s.v[:, mesh.X[0] < 1e-12] = 0.0
    return s


def _time(state, steps: int, threads: int):
    from solver.fem3d import loop

    loop.advance(state, 2, threads=threads)  # warm-up (compiles once)
    w0, c0 = time.perf_counter(), time.process_time()
    rec = loop.advance(state, steps, threads=threads)
    w1, c1 = time.perf_counter(), time.process_time()
    return rec, w1 - w0, c1 - c0


def bench(threads=(1, 2), sizes=(10_000, 100_000, 1_000_000)) -> list[dict]:
    """One row per (size, threads): hexahedron updates per second (wall and CPU), the speedup, the cost per
    element against the smallest size."""
    base_ns: dict[int, float] = {}

    def timed_row(state, ne: int, steps: int, t: int) -> dict:
        rec, wall, cpu = _time(state, steps, t)
        rate = ne * rec.steps / wall
        ns = 1e9 * wall / (ne * rec.steps)
        base_ns.setdefault(t, ns)
        return {"dim": 3, "elements": ne, "nodes": state.x.shape[1], "threads": t, "steps": rec.steps,
                "wall_s": round(wall, 4), "element_updates_per_s": rate,
                "element_updates_per_cpu_s": ne * rec.steps / max(cpu, 1e-9), "ns_per_element_update": ns,
                "cost_vs_smallest": ns / base_ns[t], "status": rec.status}

    return sweep(sizes, threads, _state, lambda state: state.hexes.shape[0], timed_row)


if __name__ == "__main__":  # python -m solver.bench_fem3d
    import json
    import sys

    sizes = [int(float(s)) for s in sys.argv[1:]] or [10_000, 100_000]
    print(json.dumps(bench([1], sizes), indent=1))
