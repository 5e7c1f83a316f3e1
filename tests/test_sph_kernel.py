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


def test_cell_list_refuses_a_dispersed_cloud():
    x = np.array([0.0, 1.0e6])
    y = np.zeros(2)
    act = np.arange(2, dtype=np.int64)
    assert cell_neighbours(x, y, act, 2, 1e-3) == []  # grid over budget: build_cells says not ok
