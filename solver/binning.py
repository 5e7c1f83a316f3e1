"""Counting sort of items into the cells of a uniform grid, as a compressed cell list (CSR).

Each item k covers a rectangle of cells ``box[k] = (i0, i1, j0, j1)`` (inclusive cell ranges, cell
(i, j) has id j ncx + i; ``i0 < 0`` leaves the item out): a point or an edge binned by its midpoint
covers one cell, an edge or an element binned by its bounding box a block of them, so a query needs
to look into its own cell (or its block of cells) only. Two passes over the items (Knuth, TAOCP
vol. 3, sec. 5.2, Algorithm D, distribution counting): :func:`count_boxes` counts the entries per cell
and turns the counts into row starts, :func:`fill_boxes` writes the item ids; the items of cell c are
then ``items[start[c]:start[c + 1]]``, in increasing (or, on request, decreasing) item order. Cost
O(items + cells + entries), no allocation: the caller owns ``start`` (cells + 1) and ``items``.

Used by the fragment contact's edge lists and the hybrid's edge lists (:mod:`solver.contact`) and by
the particle coupling's element lists (:func:`solver.sph.coupling.bin_elements`); the particles' cell lists
(:mod:`solver.sph.cells`, :mod:`solver.sph3d.cells`) end their counting sort with :func:`sort_by_cell`.

In 3D the boxes are not stored: :func:`count_hulls3d` and :func:`fill_hulls3d` bin items given as rows
of node ids (a hexahedron's 8, a face's 4) by the cells their bounding box, grown by a pad, overlaps in
a grid ``[x0, y0, z0, cell, nx, ny, nz, ...]`` of cubic cells (cell (i, j, k) has id (k ny + j) nx + i),
recomputing each item's box in both passes (the same two passes, no per-item storage). Items are
clamped into the grid's border cells or, with ``skip_outside``, left out when wholly outside it. Used
by the 3D fragment contact's face lists (:mod:`solver.fem3d.contact3d`) and the 3D hybrid's face and
element lists (:mod:`solver.hybrid.faces3d`).
"""

from __future__ import annotations

import numba


@numba.njit(cache=True)
def count_boxes(box, ncx, start):
    """Row starts of the cell list of the items' cell boxes into ``start`` (length cells + 1, start[0] = 0,
    start[c + 1] - start[c] the entries of cell c); returns the total number of entries."""
    for c in range(start.shape[0]):
        start[c] = 0
    for k in range(box.shape[0]):
        if box[k, 0] < 0:
            continue
        for jj in range(box[k, 2], box[k, 3] + 1):
            for ii in range(box[k, 0], box[k, 1] + 1):
                start[jj * ncx + ii + 1] += 1
    for c in range(1, start.shape[0]):
        start[c] += start[c - 1]
    return start[start.shape[0] - 1]


@numba.njit(cache=True)
def fill_boxes(box, ncx, start, items, descending=False):
    """The item ids k into ``items`` at the rows :func:`count_boxes` left in ``start`` (items must hold
    the total it returned), in increasing k within a cell, or decreasing with ``descending``; ``start``
    is left as it was (each row's start runs ahead while it is filled, then is shifted back)."""
    n = box.shape[0]
    for kk in range(n):
        k = n - 1 - kk if descending else kk
        if box[k, 0] < 0:
            continue
        for jj in range(box[k, 2], box[k, 3] + 1):
            for ii in range(box[k, 0], box[k, 1] + 1):
                c = jj * ncx + ii
                items[start[c]] = k
                start[c] += 1
    for c in range(start.shape[0] - 1, 0, -1):
        start[c] = start[c - 1]
    start[0] = 0


@numba.njit(cache=True)
def sort_by_cell(count, cell_of, n, act, order):
    """The second half of the counting sort of n points binned one cell each (Algorithm D, module docstring):
    ``count`` (cells + 1), holding at c + 1 the number of points of cell c (``cell_of[k]`` the cell of point k),
    becomes the row starts, and the points go into ``order`` by cell, in their order within a cell: point k
    is act[k], or k itself when ``act`` is None."""
    for c in range(count.shape[0] - 1):
        count[c + 1] += count[c]
    fill = count[:-1].copy()
    for k in range(n):
        c = cell_of[k]
        if act is None:
            order[fill[c]] = k
        else:
            order[fill[c]] = act[k]
        fill[c] += 1


@numba.njit(cache=True, inline="always")
def cell_of(p, x0, cell, n):
    """The cell of coordinate p on an axis of n cells of size ``cell`` from x0, clamped to 0 .. n - 1."""
    return min(max(int((p - x0) / cell), 0), n - 1)


@numba.njit(cache=True, inline="always")
def point_cell3d(px, py, pz, x0, y0, z0, cell, nx, ny, nz):
    """The flat index (k ny + j) nx + i of the cell of a 3D grid (origin (x0, y0, z0), cubic cells of size
    ``cell``, nx x ny x nz of them) holding the point p, clamped into the grid (:func:`cell_of`)."""
    return ((cell_of(pz, z0, cell, nz) * ny + cell_of(py, y0, cell, ny)) * nx + cell_of(px, x0, cell, nx))


@numba.njit(cache=True, inline="always")
def _hull_cells(x, items, e, ncol, grid, pad, skip_outside):
    """(inside, i0, i1, j0, j1, k0, k1): the cell box of item e's bounding box grown by pad (module docstring)."""
    lx = ly = lz = 1e300
    ux = uy = uz = -1e300
    for k in range(ncol):
        nd = items[e, k]
        lx = min(lx, x[0, nd])
        ux = max(ux, x[0, nd])
        ly = min(ly, x[1, nd])
        uy = max(uy, x[1, nd])
        lz = min(lz, x[2, nd])
        uz = max(uz, x[2, nd])
    cell = grid[3]
    nx, ny, nz = int(grid[4]), int(grid[5]), int(grid[6])
    if skip_outside and (ux + pad < grid[0] or lx - pad > grid[0] + nx * cell or uy + pad < grid[1]
                         or ly - pad > grid[1] + ny * cell or uz + pad < grid[2] or lz - pad > grid[2] + nz * cell):
        return False, 0, -1, 0, -1, 0, -1
    return (True, cell_of(lx - pad, grid[0], cell, nx), cell_of(ux + pad, grid[0], cell, nx),
            cell_of(ly - pad, grid[1], cell, ny), cell_of(uy + pad, grid[1], cell, ny),
            cell_of(lz - pad, grid[2], cell, nz), cell_of(uz + pad, grid[2], cell, nz))


@numba.njit(cache=True)
def _hulls3d_pass(x, items, ncol, grid, pad, skip_outside, start, ent, fill):
    """One pass over the items: count each (item, cell) entry into start[c + 1], or write the item id at
    start[c] and advance it (``fill``)."""
    nx, ny = int(grid[4]), int(grid[5])
    for e in range(items.shape[0]):
        inside, i0, i1, j0, j1, k0, k1 = _hull_cells(x, items, e, ncol, grid, pad, skip_outside)
        if not inside:
            continue
        for kk in range(k0, k1 + 1):
            for jj in range(j0, j1 + 1):
                for ii in range(i0, i1 + 1):
                    c = (kk * ny + jj) * nx + ii
                    if fill:
                        ent[start[c]] = e
                        start[c] += 1
                    else:
                        start[c + 1] += 1


@numba.njit(cache=True)
def count_hulls3d(x, items, ncol, grid, pad, skip_outside, start):
    """Row starts of the 3D cell list of the items (the first ``ncol`` node ids of each row of ``items``,
    positions x (3, n)) into ``start`` (cells + 1); returns the total number of entries."""
    for c in range(start.shape[0]):
        start[c] = 0
    _hulls3d_pass(x, items, ncol, grid, pad, skip_outside, start, start[:0], False)
    for c in range(1, start.shape[0]):
        start[c] += start[c - 1]
    return start[start.shape[0] - 1]


@numba.njit(cache=True)
def fill_hulls3d(x, items, ncol, grid, pad, skip_outside, start, ent):
    """The item ids into ``ent`` at the rows :func:`count_hulls3d` left in ``start`` (ent must hold the
    total it returned), in increasing item order within a cell; ``start`` is left as it was."""
    _hulls3d_pass(x, items, ncol, grid, pad, skip_outside, start, ent, True)
    for c in range(start.shape[0] - 1, 0, -1):
        start[c] = start[c - 1]
    start[0] = 0
