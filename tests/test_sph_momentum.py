"""The momentum equation's pair loop (solver.sph.solid.momentum): each pair visited once (half
stencil), per-chunk accumulators. Checked against a direct O(N^2) evaluation of Gray, Monaghan &
Swift (2001) eqs. 1 and 26 with the corrected gradients, artificial viscosity and artificial stress,
and against momentum conservation, for any number of chunks."""

import numpy as np
import pytest

from solver.sph import loop, materials as mt, particles as pp, solid
from solver.sph.kernel import gradw_factor, w_cubic


def _cloud(seed=5):
    """A jittered block with a sparse corner (some particles fall back to B = I), random velocities
    (viscosity acts on the approaching pairs) and random stresses with tension (artificial stress)."""
    rng = np.random.default_rng(seed)
    dp = 1e-6
    x, y = pp.lattice(0.0, 14 * dp, 0.0, 10 * dp, dp)
    keep = ~((x > 10 * dp) & (y > 6 * dp) & (rng.random(x.size) < 0.6))
    x, y = x[keep] + 0.2 * dp * rng.standard_normal(keep.sum()), y[keep] + 0.2 * dp * rng.standard_normal(keep.sum())
    mats = mt.table(mt.isotropic(2.96e9, 0.4, 1280.0))
    P = pp.from_points(x, y, mats, pp.make_params(dp), vx=5 * rng.standard_normal(x.size),
                       vy=5 * rng.standard_normal(x.size))
    P.F[pp.M] *= 1 + 0.3 * rng.random(x.size)  # unequal masses: the pair terms carry m_i and m_j
    P.F[pp.RHO] *= 1 + 0.05 * rng.standard_normal(x.size)
    P.F[pp.SXX] = 4e7 * rng.standard_normal(x.size)
    P.F[pp.SYY] = 4e7 * rng.standard_normal(x.size)
    P.F[pp.SXY] = 2e7 * rng.standard_normal(x.size)
    loop.step_chunk(P, 1, 0.1 * loop.stable_dt(P))  # one step: the corrected gradients B of this cloud
    return P


def _forces(P, n_chunks):
    order, cell_of, _ = loop._buffers(P)
    A = solid.pair_buffers(P.n, n_chunks)
    assert loop.compute_forces(P.F, P.I, P.S, A, P.act, P.n_act, P.mats, P.prm, order, cell_of)
    return P.F[pp.AX].copy(), P.F[pp.AY].copy()


def _direct(P):
    """dv_i/dt = sum_j m_j (P_i B_i g + P_j B_j g + (f^n (R_i + R_j) - Pi_ij I) g), g = grad_i W_ij,
    P = sigma / rho^2, over all pairs within 2h, from the state compute_forces left (B, acting
    stress, R, c)."""
    F, prm = P.F, P.prm
    h, alpha, beta, eps, nexp, wdp = (prm[pp.P_H], prm[pp.P_ALPHA], prm[pp.P_BETA], prm[pp.P_EPS],
                                      int(prm[pp.P_NEXP]), prm[pp.P_WDP])
    n = P.n_act
    a = np.zeros((n, 2))
    Pst = [np.array([[F[pp.ESXX, i], F[pp.ESXY, i]], [F[pp.ESXY, i], F[pp.ESYY, i]]]) / F[pp.RHO, i] ** 2
           for i in range(n)]
    B = [np.array([[F[pp.BXX, i], F[pp.BXY, i]], [F[pp.BYX, i], F[pp.BYY, i]]]) for i in range(n)]
    R = [np.array([[F[pp.RXX, i], F[pp.RXY, i]], [F[pp.RXY, i], F[pp.RYY, i]]]) for i in range(n)]
    for i in range(n):
        for j in range(n):
            d = np.array([F[pp.X, i] - F[pp.X, j], F[pp.Y, i] - F[pp.Y, j]])
            r = float(np.hypot(*d))
            if i == j or r >= 2 * h:
                continue
            g = gradw_factor(r, h) * d
            dv = np.array([F[pp.VX, i] - F[pp.VX, j], F[pp.VY, i] - F[pp.VY, j]])
            T = np.zeros((2, 2))
            if dv @ d < 0:
                mu = h * (dv @ d) / (r * r + 0.01 * h * h)
                T -= (-alpha * 0.5 * (F[pp.CS, i] + F[pp.CS, j]) * mu + beta * mu * mu) / (
                    0.5 * (F[pp.RHO, i] + F[pp.RHO, j])) * np.eye(2)
            fn = (w_cubic(r, h) / wdp) ** nexp
            if eps > 0 and fn > 1e-6:  # the solver skips the artificial stress where f^n < 1e-6
                T += fn * (R[i] + R[j])
            a[i] += F[pp.M, j] * (Pst[i] @ (B[i] @ g) + Pst[j] @ (B[j] @ g) + T @ g)
    return a


@pytest.mark.parametrize("n_chunks", [1, 3])
def test_half_stencil_pair_loop_equals_the_direct_sum_and_conserves_momentum(n_chunks):
    P = _cloud()
    ax, ay = _forces(P, n_chunks)
    ref = _direct(P)
    scale = np.abs(ref).max()
    assert np.abs(ax - ref[:, 0]).max() < 1e-10 * scale
    assert np.abs(ay - ref[:, 1]).max() < 1e-10 * scale
    m = P.F[pp.M, : P.n_act]
    # internal forces only: the total momentum change vanishes to round-off
    assert abs(np.sum(m * ax)) < 1e-12 * np.sum(m * np.abs(ax))
    assert abs(np.sum(m * ay)) < 1e-12 * np.sum(m * np.abs(ay))
    # there is something to check: some particles fell back to B = I, the rest were corrected
    assert 0 < np.sum(P.F[pp.BXX, : P.n_act] == 1.0) < P.n_act


def test_the_forces_do_not_depend_on_the_number_of_chunks_beyond_round_off():
    ax1, ay1 = _forces(_cloud(), 1)
    ax4, ay4 = _forces(_cloud(), 4)
    s = np.abs(ax1).max()
    assert np.abs(ax1 - ax4).max() < 1e-12 * s and np.abs(ay1 - ay4).max() < 1e-12 * s
