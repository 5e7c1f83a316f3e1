"""The optional quadratic-complete surface gradient (solver.sph.quadratic): exact for quadratic
velocity fields at the free surface, and the momentum equation its exact transpose (stress power
sum_i V_i sigma_i : L_i = -sum_i m_i a_i . v_i, momentum conserved)."""

import numpy as np

from solver.sph import loop, materials as mt, particles as pp, quadratic as qd, solid
from solver.sph.cells import NSTEN, build_cells
from solver.sph.kernel import SUPPORT


def _block(quadratic):
    dp = 1e-3
    x, y = pp.lattice(0.0, 12 * dp, 0.0, 8 * dp, dp)
    mats = mt.table(mt.isotropic(2e6, 0.3, 1000.0))
    P = pp.from_points(x, y, mats, pp.make_params(dp, eps=0.0, alpha=0.0, beta=0.0, quadratic=quadratic))
    return P, x / dp, y / dp, dp


def _gradient(P):
    order, cell_of, A = loop._buffers(P)
    start, ncx, ncy, x0, y0, cell, ok = build_cells(P.F[pp.X], P.F[pp.Y], P.act, P.n_act, SUPPORT * P.h / NSTEN,
                                                    order, cell_of)
    assert ok
    solid.gather_kinematics(P.F, P.S, order, P.n_act)
    qd.velocity_gradient_q(P.F, P.S, P.quad, order, P.n_act, start, ncx, ncy, x0, y0, cell, P.h, P.prm[pp.P_QUAD])
    return order, A, (start, ncx, ncy, x0, y0, cell)


def test_only_scenes_that_ask_for_it_carry_the_quadratic_arrays():
    assert _block(0.0)[0].quad is None
    assert _block(0.6)[0].quad.shape == (8 * 12, qd.NQ)


def test_quadratic_velocity_field_has_its_exact_gradient_at_the_free_surface():
    P, X, Y, dp = _block(0.95)
    P.F[pp.VX] = 0.3 * X + 0.1 * Y + 0.05 * X * X - 0.02 * X * Y + 0.03 * Y * Y
    P.F[pp.VY] = -0.2 * X + 0.4 * Y + 0.01 * X * X + 0.04 * X * Y - 0.06 * Y * Y
    _gradient(P)
    quad = P.quad[:, 0] > 0
    surface = (X < 1) | (X > 11) | (Y < 1) | (Y > 7)
    assert quad[surface].all()  # the outermost rows (and the next: s_min < 0.95) use the quadratic form
    exact = {pp.LXX: (0.3 + 0.1 * X - 0.02 * Y) / dp, pp.LXY: (0.1 - 0.02 * X + 0.06 * Y) / dp,
             pp.LYX: (-0.2 + 0.02 * X + 0.04 * Y) / dp, pp.LYY: (0.4 + 0.04 * X - 0.12 * Y) / dp}
    for row, g in exact.items():
        assert np.allclose(P.F[row, quad], g[quad], rtol=0, atol=1e-9 * np.abs(g).max())
    # the first-order form is off by O(h) at the surface for the same field
    Q, *_ = _block(0.0)
    Q.F[pp.VX] = P.F[pp.VX]
    Q.F[pp.VY] = P.F[pp.VY]
    from test_sph_solid import _velocity_gradient
    L = _velocity_gradient(Q)
    assert np.abs(L[0, 0][surface] - exact[pp.LXX][surface]).max() > 1e-3 * np.abs(exact[pp.LXX]).max()


def test_momentum_is_the_transpose_of_the_velocity_gradient():
    P, X, Y, dp = _block(0.95)
    rng = np.random.default_rng(1)
    for r in (pp.SXX, pp.SYY, pp.SXY):
        P.F[r] = 1e3 * rng.standard_normal(P.n)
    P.F[pp.VX] = rng.standard_normal(P.n)
    P.F[pp.VY] = rng.standard_normal(P.n)
    P.F[pp.RHO] *= 1 + 0.05 * rng.standard_normal(P.n)
    order, A, cells = _gradient(P)
    assert (P.quad[:, 0] > 0).sum() > 0
    solid.update_state(P.F, P.I, P.act, P.n_act, P.mats, P.prm, 0.0)
    solid.gather_stress(P.F, P.S, order, P.n_act)
    qd.momentum_q(P.F, P.I, P.S, A, P.quad, order, P.n_act, *cells, P.prm)
    F = P.F
    V = F[pp.M] / F[pp.RHO]
    power = np.sum(V * (F[pp.ESXX] * F[pp.LXX] + F[pp.ESYY] * F[pp.LYY] + F[pp.ESXY] * (F[pp.LXY] + F[pp.LYX])))
    fv = np.sum(F[pp.M] * (F[pp.AX] * F[pp.VX] + F[pp.AY] * F[pp.VY]))
    assert abs(power + fv) < 1e-12 * abs(power)
    scale = np.abs(F[pp.M] * F[pp.AX]).max()
    assert abs(np.sum(F[pp.M] * F[pp.AX])) < 1e-12 * scale and abs(np.sum(F[pp.M] * F[pp.AY])) < 1e-12 * scale
