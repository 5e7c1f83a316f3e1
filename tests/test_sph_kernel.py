"""Cubic-spline kernel and cell-list neighbour search (solver.sph.kernel, solver.sph.cells)."""


import numpy as np
import pytest

from solver.sph.cells import brute_neighbours, cell_neighbours
from solver.sph.kernel import gradw_factor, w_cubic


@pytest.mark.parametrize("h", [0.5, 1.3, 2.0])
def test_kernel_integrates_to_one(h):
    # midpoint quadrature over the support disc: int W dA = 1 (Monaghan 2005, eq. 2.4)
    n = 600
    s = np.linspace(-2 * h, 2 * h, n + 1)
    c = 0.5 * (s[1:] + s[:-1])
    X, Y = np.meshgrid(c, c)
    r = np.hypot(X, Y).ravel()
    total = sum(w_cubic(float(ri), h) for ri in r) * (s[1] - s[0]) ** 2
    assert total == pytest.approx(1.0, abs=2e-4)


def test_gradient_matches_finite_difference():
    h = 1.3
    for r in [1e-3, 0.3, 0.99, 1.0, 1.01, 1.5, 1.99, 2.0, 2.5]:
        eps = 1e-6
        dwdr = (w_cubic(r + eps, h) - w_cubic(max(r - eps, 0.0), h)) / (r + eps - max(r - eps, 0.0))
        assert gradw_factor(r, h) * r == pytest.approx(dwdr, rel=1e-5, abs=1e-9)
    assert w_cubic(2.0 * h, h) == 0.0 and gradw_factor(2.0 * h, h) == 0.0


def test_cell_list_finds_exactly_the_brute_force_pairs():
    rng = np.random.default_rng(7)
    n = 700
    x = rng.uniform(0, 1, n)
    y = rng.uniform(0, 0.4, n)
    x[:50] += 3.0  # a distant cluster: the grid spans empty cells
    act = np.flatnonzero(rng.uniform(size=n) < 0.8).astype(np.int64)  # dormant particles excluded
    radius = 0.05
    cells = sorted(cell_neighbours(x, y, act, act.size, radius))
    brute = sorted(brute_neighbours(x, y, act, act.size, radius))
    assert len(brute) > 500
    assert cells == brute


def test_cell_list_coarsens_for_a_dispersed_cloud_and_stays_exact():
    """A sparse cloud (two clusters a metre apart, debris thrown off a cut) gets cells doubled until the
    grid fits its budget; the pairs it finds are still exactly the brute-force ones. Non-finite
    positions are refused."""
    from solver.sph.cells import build_cells

    rng = np.random.default_rng(3)
    x = np.r_[rng.uniform(0, 1e-4, 200), 1.0 + rng.uniform(0, 1e-4, 200)]
    y = rng.uniform(0, 1e-4, 400)
    act = np.arange(400, dtype=np.int64)
    radius = 1.5e-5
    _, ncx, ncy, _, _, cell, ok = build_cells(x, y, act, 400, radius / 2, np.empty(400, np.int64), np.empty(400, np.int64))
    assert ok and cell > radius / 2 and ncx * ncy <= 64 * 400 + (1 << 16)
    assert sorted(cell_neighbours(x, y, act, 400, radius)) == sorted(brute_neighbours(x, y, act, 400, radius))
    x[5] = np.nan
    assert not build_cells(x, y, act, 400, radius / 2, np.empty(400, np.int64), np.empty(400, np.int64))[-1]
