"""O(N) cell-list neighbour search in 3D.

A uniform grid of cubic cells of side ``cell`` = support / NSTEN (= 2h / 2 = h) covers the bounding
box of the particles; a counting sort orders the particles by cell (cell id (cz ncy + cy) ncx + cx),
so the candidates of a particle are the (2 NSTEN + 1)^3 cells around its own, and the cells of one
stencil row (fixed cy, cz) are contiguous in the sorted order: one loop per row (Monaghan 2005,
Rep. Prog. Phys. 68:1703, sec. 3.1; the linked-cell method; the 3D form of :mod:`solver.sph.cells`).
Building costs O(N + N_cells); the grid may hold at most MAX_CELLS_PER_PARTICLE cells per particle
(plus a floor): a sparse cloud gets cells doubled as often as needed (the search stays exact, a cell
never shrinks below support / NSTEN).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..binning import sort_by_cell

MAX_CELLS_PER_PARTICLE = 64
#: stencil half-width in cells: cells have side support / NSTEN
NSTEN = 2
#: rows (fixed cy, cz) of the half stencil: the later NSTEN + 1 of the own plane, all 2 NSTEN + 1 of the
#: NSTEN planes above
HALF_ROWS = NSTEN + 1 + NSTEN * (2 * NSTEN + 1)
MIN_CELL_BUDGET = 1 << 16


@numba.njit(cache=True, inline="always")
def cell_coords3(px, py, pz, x0, y0, z0, cell, ncx, ncy, ncz):
    """The cell (cx, cy, cz) of the point (px, py, pz): floor((p - p0) / cell), the last cell of each axis
    also holding its upper edge."""
    return (min(int((px - x0) / cell), ncx - 1), min(int((py - y0) / cell), ncy - 1),
            min(int((pz - z0) / cell), ncz - 1))


@numba.njit(cache=True, inline="always")
def half_stencil(k, cx, cy, cz, start, ncx, ncy, ncz, lo, hi):
    """The half stencil of particle k (cell order) in cell (cx, cy, cz): the particles l > k of the
    (2 NSTEN + 1)^3 cells around it, as contiguous cell-order ranges lo[r] <= l < hi[r], one per stencil
    row (fixed cy, cz) from the own row on (its rest from k + 1) in cell id order; each pair of the full
    stencil is seen from exactly one of its particles (the half shell of the linked-cell method; Allen &
    Tildesley 1987, Computer Simulation of Liquids, ch. 5). Returns the number of rows (at most HALF_ROWS)."""
    lo_x = max(cx - NSTEN, 0)
    hi_x = min(cx + NSTEN, ncx - 1)
    nr = 0
    for nz in range(cz, min(cz + NSTEN + 1, ncz)):
        ny0 = cy if nz == cz else max(cy - NSTEN, 0)
        for ny in range(ny0, min(cy + NSTEN + 1, ncy)):
            row = (nz * ncy + ny) * ncx
            lo[nr] = k + 1 if (nz == cz and ny == cy) else start[row + lo_x]
            hi[nr] = start[row + hi_x + 1]
            nr += 1
    return nr


@numba.njit(cache=True, inline="always")
def closer3(x, i, j, radius):
    """|x_i - x_j| < radius for points i, j of x (3, n)."""
    d2 = 0.0
    for c in range(3):
        d = x[c, i] - x[c, j]
        d2 += d * d
    return d2 < radius * radius


@numba.njit(cache=True)
def build_cells3(x, n, cell, order, cell_of):
    """Counting-sort particles 0..n-1 (positions x (3, n)) into cubic cells of side ``cell``.

    Returns (cell_start, ncx, ncy, ncz, x0, y0, z0, cell_used, ok): the particles of cell c are
    ``order[cell_start[c]:cell_start[c + 1]]``; ``cell_of[i]`` is the cell of particle i; cell
    (cx, cy, cz) has id (cz ncy + cy) ncx + cx with cx = floor((x - x0) / cell_used). ``ok`` is False
    only for non-finite positions.
    """
    lo = np.full(3, math.inf)
    hi = np.full(3, -math.inf)
    for i in range(n):
        for c in range(3):
            v = x[c, i]
            if not math.isfinite(v):
                return np.zeros(1, np.int64), 0, 0, 0, 0.0, 0.0, 0.0, cell, False
            if v < lo[c]:
                lo[c] = v
            if v > hi[c]:
                hi[c] = v
    if n == 0:
        return np.zeros(1, np.int64), 0, 0, 0, 0.0, 0.0, 0.0, cell, True
    fx = (hi[0] - lo[0]) / cell
    fy = (hi[1] - lo[1]) / cell
    fz = (hi[2] - lo[2]) / cell
    budget = MAX_CELLS_PER_PARTICLE * n + MIN_CELL_BUDGET
    while (fx + 1.0) * (fy + 1.0) * (fz + 1.0) > budget:
        cell *= 2.0
        fx *= 0.5
        fy *= 0.5
        fz *= 0.5
    ncx = int(fx) + 1
    ncy = int(fy) + 1
    ncz = int(fz) + 1
    ncell = ncx * ncy * ncz
    x0 = lo[0]
    y0 = lo[1]
    z0 = lo[2]
    count = np.zeros(ncell + 1, np.int64)
    for i in range(n):
        cx, cy, cz = cell_coords3(x[0, i], x[1, i], x[2, i], x0, y0, z0, cell, ncx, ncy, ncz)
        c = (cz * ncy + cy) * ncx + cx
        cell_of[i] = c
        count[c + 1] += 1
    sort_by_cell(count, cell_of, n, None, order)
    return count, ncx, ncy, ncz, x0, y0, z0, cell, True


@numba.njit(cache=True)
def brute_neighbours3(x, radius):
    """All pairs (i < j) closer than ``radius``, by O(N^2) search (tests only)."""
    out = []
    n = x.shape[1]
    for i in range(n):
        for j in range(i + 1, n):
            if closer3(x, i, j, radius):
                out.append((i, j))
    return out


@numba.njit(cache=True)
def cell_neighbours3(x, radius):
    """All pairs (i < j) closer than ``radius``, through :func:`build_cells3` and the production
    half stencil (:func:`half_stencil`, cells of side radius / NSTEN)."""
    n = x.shape[1]
    order = np.empty(n, np.int64)
    cell_of = np.empty(n, np.int64)
    start, ncx, ncy, ncz, x0, y0, z0, cell, ok = build_cells3(x, n, radius / NSTEN, order, cell_of)
    out = []
    if not ok:
        return out
    lo = np.empty(HALF_ROWS, np.int64)
    hi = np.empty(HALF_ROWS, np.int64)
    for k in range(n):
        i = order[k]
        cx, cy, cz = cell_coords3(x[0, i], x[1, i], x[2, i], x0, y0, z0, cell, ncx, ncy, ncz)
        for r in range(half_stencil(k, cx, cy, cz, start, ncx, ncy, ncz, lo, hi)):
            for l in range(lo[r], hi[r]):
                j = order[l]
                if closer3(x, i, j, radius):
                    out.append((min(i, j), max(i, j)))
    return out
