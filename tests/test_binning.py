"""The counting sort into CSR cell lists (solver.binning) against the definition: cell c lists exactly
the items whose cell box covers it, each once, in increasing (or decreasing) item order."""

import numpy as np

from solver.binning import count_boxes, fill_boxes


def _boxes(rng, n, ncx, ncy):
    i0 = rng.integers(0, ncx, n)
    j0 = rng.integers(0, ncy, n)
    i1 = np.minimum(i0 + rng.integers(0, 3, n), ncx - 1)
    j1 = np.minimum(j0 + rng.integers(0, 3, n), ncy - 1)
    box = np.stack([i0, i1, j0, j1], axis=1).astype(np.int64)
    box[rng.random(n) < 0.2, 0] = -1  # left out
    return box


def test_every_cell_lists_the_items_whose_box_covers_it_in_order():
    rng = np.random.default_rng(3)
    ncx, ncy, n = 7, 5, 60
    box = _boxes(rng, n, ncx, ncy)
    for descending in (False, True):
        start = np.empty(ncx * ncy + 1, np.int64)
        total = count_boxes(box, ncx, start)
        expected_total = sum((b[1] - b[0] + 1) * (b[3] - b[2] + 1) for b in box if b[0] >= 0)
        assert total == expected_total and start[0] == 0 and start[-1] == total
        items = np.full(total, -7, np.int64)
        fill_boxes(box, ncx, start, items, descending)
        assert start[-1] == total and np.all(np.diff(start) >= 0)  # the row starts are left as counted
        for j in range(ncy):
            for i in range(ncx):
                c = j * ncx + i
                want = [k for k in range(n) if box[k, 0] >= 0 and box[k, 0] <= i <= box[k, 1]
                        and box[k, 2] <= j <= box[k, 3]]
                got = list(items[start[c]:start[c + 1]])
                assert got == (want[::-1] if descending else want), (c, got, want)


def test_an_empty_set_gives_empty_rows():
    start = np.full(13, 5, np.int64)
    assert count_boxes(np.empty((0, 4), np.int64), 4, start) == 0
    fill_boxes(np.empty((0, 4), np.int64), 4, start, np.empty(0, np.int64))
    assert np.all(start == 0)


def test_3d_hulls_list_each_item_in_every_cell_its_grown_box_overlaps():
    from solver.binning import count_hulls3d, fill_hulls3d
    rng = np.random.default_rng(5)
    x = rng.uniform(-1.0, 5.0, (3, 40))             # some nodes outside the grid [0, 4)^3
    items = rng.integers(0, 40, (30, 4)).astype(np.int64)
    grid = np.array([0.0, 0.0, 0.0, 1.0, 4, 4, 4])
    pad = 0.25
    for skip in (False, True):
        start = np.empty(4 ** 3 + 1, np.int64)
        total = count_hulls3d(x, items, 4, grid, pad, skip, start)
        ent = np.full(total, -1, np.int64)
        fill_hulls3d(x, items, 4, grid, pad, skip, start, ent)
        assert start[0] == 0 and start[-1] == total
        for e in range(items.shape[0]):
            lo = x[:, items[e]].min(axis=1) - pad
            hi = x[:, items[e]].max(axis=1) + pad
            outside = np.any(hi < 0.0) or np.any(lo > 4.0)
            i0 = np.clip(np.floor(lo).astype(int), 0, 3)
            i1 = np.clip(np.floor(hi).astype(int), 0, 3)
            for k in range(4):
                for j in range(4):
                    for i in range(4):
                        c = (k * 4 + j) * 4 + i
                        want = (not (skip and outside)) and i0[0] <= i <= i1[0] and i0[1] <= j <= i1[1] \
                            and i0[2] <= k <= i1[2]
                        assert (e in ent[start[c]:start[c + 1]]) == want, (skip, e, c)
        for c in range(4 ** 3):
            row = ent[start[c]:start[c + 1]]
            assert np.all(np.diff(row) > 0)            # each item once, in increasing order


def test_a_point_falls_in_the_cell_that_holds_it_clamped_into_the_grid():
    from solver.binning import point_cell3d

    rng = np.random.default_rng(3)
    x0, cell, n = np.array([-1.0, 0.5, 2.0]), 0.25, np.array([4, 3, 5])
    for p in rng.uniform(-2.0, 4.0, (200, 3)):
        ijk = np.clip(np.floor((p - x0) / cell).astype(int), 0, n - 1)  # outside: the nearest cell
        want = (ijk[2] * n[1] + ijk[1]) * n[0] + ijk[0]
        assert point_cell3d(*p, *x0, cell, *n) == want
