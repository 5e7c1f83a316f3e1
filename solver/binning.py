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
the particle coupling's element lists (:func:`solver.sph.coupling.bin_elements`).
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
