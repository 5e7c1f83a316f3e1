"""Quadratic-complete gradient at the free surface of solid SPH (optional, off in production).

The first-order corrected gradient B_i grad_i W_ij (Randles & Libersky 1996; Bonet & Lok 1999;
:func:`solver.sph.solid.velocity_gradient`) is exact for linear fields everywhere, and in the interior
the symmetric support also cancels the quadratic error; at a free surface the one-sided support leaves
an O(h) error for a quadratic field, which is what makes a bending plate too soft (the outermost row
of a plate 10 particles thick sees 0.93 of the bending strain; the case ``sph-plate``). Here the particles
whose support is cut (smallest singular value of the moment matrix M_i below ``prm[P_QUAD]``) take
instead the moving-least-squares gradient with the complete quadratic basis (Lancaster & Salkauskas
1981, Math. Comp. 37:141; Belytschko, Krongauz, Organ, Fleming & Krysl 1996, CMAME 139:3; the
Taylor-series form of Liu, Liu & Lam 2003, the finite particle method, restricted to the first
derivatives):

    P(e) = (e_x, e_y, e_x^2, e_x e_y, e_y^2),   e = (x_j - x_i) / h,
    A_i  = sum_j V_j omega_ij P(e_ij) P(e_ij)^T,    C_i = [I_2 0] A_i^-1 / h,
    L_i  = sum_j (v_j - v_i) (x) w_ij,               w_ij = V_j omega_ij C_i P(e_ij),
    omega_ij = -h r_ij dW/dr (r_ij)   (the weight of the kernel gradient: 0 at r = 0),

exact for every quadratic velocity field wherever A_i is invertible (for any weight). The weight is
that of the kernel gradient the other particles use, not W itself: with omega = W (largest at the
nearest neighbours) the surface rows of the oscillating plate clumped within T/20 at Gray et al.'s
amplitude (n = 8, mirror clamp, eps = 0 and 0.3; stable at V_f = 0.001), with omega = -h r W' the plate runs
as stably as with the first-order form (nearest neighbour 0.88 dp over 1.3 periods). The momentum equation uses the
transpose (:func:`momentum_q`), so the stress power is exactly sum_i V_i sigma_i : L_i. The other
particles keep B_i grad_i W_ij. Enabled by ``make_params(quadratic=s)`` (the particles then carry
Q = float64[n, 11]: flag, C_i); every other scene has no such array, and its step skips these terms.

The pair loops are those of solid SPH (:func:`solver.sph.solid.velocity_gradient_pass`,
:func:`solver.sph.solid.momentum_pass`, which take Q), with the moving-least-squares pieces of
:mod:`solver.sph.mls`; the functions here are their quadratic entry points.
"""

from __future__ import annotations

import numba

from .mls import NQ, PIVOT_MIN  # noqa: F401  (Q's width and the pivot limit, named here with the method)
from .solid import momentum_pass, refresh_for_forces, velocity_gradient_pass


@numba.njit(cache=True)
def velocity_gradient_q(F, S, Q, order, n_act, start, ncx, ncy, x0, y0, cell, h, smax):
    """Velocity gradient of :func:`solver.sph.solid.velocity_gradient` (Gray et al. 2001 eq. 2 with
    the first-order correction B_i = M_i^-T of Randles & Libersky 1996 / Bonet & Lok 1999), except
    where the support is cut (smallest singular value of M_i below ``smax``, and at least SMIN_CORR):
    there the quadratic-complete moving-least-squares gradient of the module docstring (Lancaster &
    Salkauskas 1981; Belytschko et al. 1996), L_i = sum_j (v_j - v_i) (x) V_j omega_ij C_i P(e_ij),
    omega_ij = -h r_ij W'(r_ij).
    Writes LXX, LXY, LYX, LYY, RMIN, BXX, BXY, BYX, BYY of F and the row Q[i] (flag, C_i; flag 0 and
    B_i in use where the first-order form is kept): :func:`solver.sph.solid.velocity_gradient_pass`."""
    velocity_gradient_pass(F, S, Q, order, n_act, start, ncx, ncy, x0, y0, cell, h, True, smax)


@numba.njit(cache=True)
def compute_forces_q(F, I, S, A, Q, act, n_act, mats, prm, order, cell_of):
    """:func:`solver.sph.loop.compute_forces` with :func:`momentum_q` (the Q rows of the last step)."""
    start, ncx, ncy, x0, y0, cell, ok = refresh_for_forces(F, I, S, act, n_act, mats, prm, order, cell_of)
    if ok:
        momentum_pass(F, I, S, A, Q, order, n_act, start, ncx, ncy, x0, y0, cell, prm)
    return ok


@numba.njit(cache=True)
def momentum_q(F, I, S, A, Q, order, n_act, start, ncx, ncy, x0, y0, cell, prm):
    """Acceleration of :func:`solver.sph.solid.momentum` (Gray et al. 2001 eqs. 1, 26; Monaghan 2005
    eqs. 3.13, 4.9), with the stress term of the particles that carry a quadratic-complete gradient
    (Q[i, 0] > 0, :func:`velocity_gradient_q`) taken as the transpose of their velocity gradient, so
    that the stress power is exactly sum_i V_i sigma_i : L_i (variational consistency; Bonet & Lok
    1999 CMAME 180:97 sec. 3; Belytschko et al. 1998 IJNME 43:785 for moving least squares):

        m_i dv_i/dt = sum_j (q_ij - q_ji) + (viscosity, artificial stress as in momentum),
        q_ij = V_i sigma_i . w_ij,   w_ij = V_j omega_ij C_i P((x_j - x_i)/h)   (quadratic particle i),
        q_ij = m_i m_j sigma_i/rho_i^2 . B_i grad_i W_ij                   (first-order corrected i),

    C_i the first two rows of A_i^-1 / h (:func:`velocity_gradient_q`), V = m / rho. Pairs are
    antisymmetric, so linear momentum is conserved. The pair loop, the viscous and artificial-stress
    terms and the energy booking are those of :func:`solver.sph.solid.momentum_pass`."""
    momentum_pass(F, I, S, A, Q, order, n_act, start, ncx, ncy, x0, y0, cell, prm)
