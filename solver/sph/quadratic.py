"""Quadratic-complete gradient at the free surface of solid SPH (optional, off in production).

The first-order corrected gradient B_i grad_i W_ij (Randles & Libersky 1996; Bonet & Lok 1999;
:func:`solver.sph.solid.velocity_gradient`) is exact for linear fields everywhere, and in the interior
the symmetric support also cancels the quadratic error; at a free surface the one-sided support leaves
an O(h) error for a quadratic field, which is what makes a bending plate too soft (the outermost row
of a plate 10 particles thick sees 0.93 of the bending strain; docs/validation.md). Here the particles
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
Q = float64[n, 11]: flag, C_i); every other scene has neither the array nor these kernels in its step.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from .cells import NSTEN
from .kernel import gradw_factor
from .particles import (BXX, BXY, BYX, BYY, GBXX, GBXY, GBYX, GBYY, GCS, GM, GPXX, GPXY, GPYY, GRHO, GRXX, GRXY, GRYY,
                        GVX, GVY, GX, GY, LXX, LXY, LYX, LYY, P_ALPHA, P_BETA, P_EPS, P_H, P_NEXP, P_WDP, RMIN)
from .solid import (A_AX, A_AY, A_SX, A_SY, A_VX, A_VY, FAST, SMIN_CORR, artificial_stress_reach2, dissipative_parts,
                    pair_dissipation,
                    refresh_for_forces, sum_chunks)

#: columns of Q: flag (1 where the quadratic gradient is used), then C_i row x (5), row y (5)
NQ = 11
#: smallest pivot of A_i (scaled by its largest diagonal entry) for which the quadratic gradient is used
PIVOT_MIN = 1e-8


@numba.njit(cache=True)
def _solve_two_rows(A, out):
    """out[0:2, :] = the first two rows of A^-1 (A symmetric 5x5, destroyed): Gaussian elimination
    with partial pivoting on [A | e_1 e_2] (A^-1 symmetric, so its first rows are the solutions of
    A z = e_1, e_2). Returns False when a pivot falls below PIVOT_MIN x the largest diagonal entry."""
    n = 5
    R = np.zeros((n, 2))
    R[0, 0] = 1.0
    R[1, 1] = 1.0
    scale = 0.0
    for a in range(n):
        scale = max(scale, abs(A[a, a]))
    if scale <= 0.0:
        return False
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if abs(A[p, c]) < PIVOT_MIN * scale:
            return False
        if p != c:
            for b in range(n):
                A[c, b], A[p, b] = A[p, b], A[c, b]
            for b in range(2):
                R[c, b], R[p, b] = R[p, b], R[c, b]
        for r in range(c + 1, n):
            f = A[r, c] / A[c, c]
            if f != 0.0:
                for b in range(c, n):
                    A[r, b] -= f * A[c, b]
                for b in range(2):
                    R[r, b] -= f * R[c, b]
    for b in range(2):
        for c in range(n - 1, -1, -1):
            s = R[c, b]
            for d in range(c + 1, n):
                s -= A[c, d] * out[b, d]
            out[b, c] = s / A[c, c]
    return True


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def velocity_gradient_q(F, S, Q, order, n_act, start, ncx, ncy, x0, y0, cell, h, smax):
    """Velocity gradient of :func:`solver.sph.solid.velocity_gradient` (Gray et al. 2001 eq. 2 with
    the first-order correction B_i = M_i^-T of Randles & Libersky 1996 / Bonet & Lok 1999), except
    where the support is cut (smallest singular value of M_i below ``smax``, and at least SMIN_CORR):
    there the quadratic-complete moving-least-squares gradient of the module docstring (Lancaster &
    Salkauskas 1981; Belytschko et al. 1996), L_i = sum_j (v_j - v_i) (x) V_j omega_ij C_i P(e_ij),
    omega_ij = -h r_ij W'(r_ij).
    Writes LXX, LXY, LYX, LYY, RMIN, BXX, BXY, BYX, BYY of F and the row Q[i] (flag, C_i; flag 0 and
    B_i in use where the first-order form is kept)."""
    rc2 = 4.0 * h * h
    ih = 1.0 / h
    for k in prange(n_act):
        i = order[k]
        xi = S[k, GX]
        yi = S[k, GY]
        vxi = S[k, GVX]
        vyi = S[k, GVY]
        cx = min(int((xi - x0) / cell), ncx - 1)
        cy = min(int((yi - y0) / cell), ncy - 1)
        lxx = 0.0
        lxy = 0.0
        lyx = 0.0
        lyy = 0.0
        mxx = 0.0
        mxy = 0.0
        myx = 0.0
        myy = 0.0
        Am = np.zeros((5, 5))
        bx = np.zeros(5)
        by = np.zeros(5)
        p = np.zeros(5)
        rmin2 = math.inf
        lo_x = max(cx - NSTEN, 0)
        hi_x = min(cx + NSTEN, ncx - 1)
        for ny in range(max(cy - NSTEN, 0), min(cy + NSTEN + 1, ncy)):
            row = ny * ncx
            for l in range(start[row + lo_x], start[row + hi_x + 1]):
                dx = xi - S[l, GX]
                dy = yi - S[l, GY]
                r2 = dx * dx + dy * dy
                if r2 >= rc2 or l == k:
                    continue
                if r2 < rmin2:
                    rmin2 = r2
                r = math.sqrt(r2)
                fw = gradw_factor(r, h)
                gx = fw * dx
                gy = fw * dy
                mj = S[l, GM]
                dvx = S[l, GVX] - vxi
                dvy = S[l, GVY] - vyi
                lxx += mj * dvx * gx
                lxy += mj * dvx * gy
                lyx += mj * dvy * gx
                lyy += mj * dvy * gy
                mxx -= mj * dx * gx
                mxy -= mj * dx * gy
                myx -= mj * dy * gx
                myy -= mj * dy * gy
                wv = -mj / S[l, GRHO] * fw * r * h
                ex = -dx * ih
                ey = -dy * ih
                p[0] = ex
                p[1] = ey
                p[2] = ex * ex
                p[3] = ex * ey
                p[4] = ey * ey
                for a in range(5):
                    wa = wv * p[a]
                    bx[a] += wa * dvx
                    by[a] += wa * dvy
                    for b in range(a, 5):
                        Am[a, b] += wa * p[b]
        ir = 1.0 / S[k, GRHO]
        bxx = 1.0
        bxy = 0.0
        byx = 0.0
        byy = 1.0
        mxx *= ir
        mxy *= ir
        myx *= ir
        myy *= ir
        det = mxx * myy - mxy * myx
        fro = mxx * mxx + mxy * mxy + myx * myx + myy * myy
        disc = max(fro * fro - 4.0 * det * det, 0.0)
        smin2 = 0.5 * (fro - math.sqrt(disc))
        if det > 0.0 and smin2 > SMIN_CORR * SMIN_CORR:
            idet = 1.0 / det
            bxx = myy * idet
            bxy = -myx * idet
            byx = -mxy * idet
            byy = mxx * idet
        lxx *= ir
        lxy *= ir
        lyx *= ir
        lyy *= ir
        F[LXX, i] = lxx * bxx + lxy * bxy
        F[LXY, i] = lxx * byx + lxy * byy
        F[LYX, i] = lyx * bxx + lyy * bxy
        F[LYY, i] = lyx * byx + lyy * byy
        F[BXX, i] = bxx
        F[BXY, i] = bxy
        F[BYX, i] = byx
        F[BYY, i] = byy
        F[RMIN, i] = math.sqrt(rmin2)
        Q[i, 0] = 0.0
        if det > 0.0 and SMIN_CORR * SMIN_CORR < smin2 < smax * smax:
            for a in range(5):
                for b in range(a):
                    Am[a, b] = Am[b, a]
            C = np.zeros((2, 5))
            if _solve_two_rows(Am, C):
                gxx = 0.0  # d vx / dx
                gxy = 0.0
                gyx = 0.0
                gyy = 0.0
                for a in range(5):
                    C[0, a] *= ih
                    C[1, a] *= ih
                    gxx += C[0, a] * bx[a]
                    gxy += C[1, a] * bx[a]
                    gyx += C[0, a] * by[a]
                    gyy += C[1, a] * by[a]
                    Q[i, 1 + a] = C[0, a]
                    Q[i, 6 + a] = C[1, a]
                Q[i, 0] = 1.0
                F[LXX, i] = gxx
                F[LXY, i] = gxy
                F[LYX, i] = gyx
                F[LYY, i] = gyy


@numba.njit(cache=True)
def compute_forces_q(F, I, S, A, Q, act, n_act, mats, prm, order, cell_of):
    """:func:`solver.sph.loop.compute_forces` with :func:`momentum_q` (the Q rows of the last step)."""
    start, ncx, ncy, x0, y0, cell, ok = refresh_for_forces(F, I, S, act, n_act, mats, prm, order, cell_of)
    if ok:
        momentum_q(F, I, S, A, Q, order, n_act, start, ncx, ncy, x0, y0, cell, prm)
    return ok


@numba.njit(parallel=True, cache=True, fastmath=FAST)
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
    antisymmetric, so linear momentum is conserved. The viscous and artificial-stress terms and the
    energy booking are those of :func:`solver.sph.solid.momentum`, whose pair loop this copies (kept
    separate so that the production kernel is untouched)."""
    h = prm[P_H]
    ih = 1.0 / h
    alpha = prm[P_ALPHA]
    beta = prm[P_BETA]
    use_as = prm[P_EPS] > 0.0
    nexp = int(prm[P_NEXP])
    iwdp = 1.0 / prm[P_WDP]
    rc2 = 4.0 * h * h
    eta2 = 0.01 * h * h
    ras2 = artificial_stress_reach2(h, iwdp, nexp) if use_as else rc2
    n_chunks = A.shape[0]
    for t in prange(n_chunks):
        k0 = t * n_act // n_chunks
        k1 = (t + 1) * n_act // n_chunks
        for k in range(k0, n_act):
            A[t, k, A_AX] = 0.0
            A[t, k, A_AY] = 0.0
            A[t, k, A_VX] = 0.0
            A[t, k, A_VY] = 0.0
            A[t, k, A_SX] = 0.0
            A[t, k, A_SY] = 0.0
        for k in range(k0, k1):
            xi = S[k, GX]
            yi = S[k, GY]
            vxi = S[k, GVX]
            vyi = S[k, GVY]
            mi = S[k, GM]
            pxi = S[k, GPXX]
            pyi = S[k, GPYY]
            pxyi = S[k, GPXY]
            rxi = S[k, GRXX]
            ryi = S[k, GRYY]
            rxyi = S[k, GRXY]
            ci = S[k, GCS]
            rhoi = S[k, GRHO]
            bxxi = S[k, GBXX]
            bxyi = S[k, GBXY]
            byxi = S[k, GBYX]
            byyi = S[k, GBYY]
            iq = order[k]
            qi = Q[iq, 0] > 0.0
            cx = min(int((xi - x0) / cell), ncx - 1)
            cy = min(int((yi - y0) / cell), ncy - 1)
            ax = 0.0
            ay = 0.0
            avx = 0.0
            avy = 0.0
            asx = 0.0
            asy = 0.0
            lo_x = max(cx - NSTEN, 0)
            hi_x = min(cx + NSTEN, ncx - 1)
            for ny in range(cy, min(cy + NSTEN + 1, ncy)):
                row = ny * ncx
                l0 = k + 1 if ny == cy else start[row + lo_x]
                for l in range(l0, start[row + hi_x + 1]):
                    dx = xi - S[l, GX]
                    dy = yi - S[l, GY]
                    r2 = dx * dx + dy * dy
                    if r2 >= rc2:
                        continue
                    r = math.sqrt(r2)
                    fw = gradw_factor(r, h)
                    gx = fw * dx
                    gy = fw * dy
                    mj = S[l, GM]
                    dvx = vxi - S[l, GVX]
                    dvy = vyi - S[l, GVY]
                    # corrected stress term: sigma_i/rho_i^2 . B_i g + sigma_j/rho_j^2 . B_j g
                    bgxi = bxxi * gx + bxyi * gy
                    bgyi = byxi * gx + byyi * gy
                    bgxj = S[l, GBXX] * gx + S[l, GBXY] * gy
                    bgyj = S[l, GBYX] * gx + S[l, GBYY] * gy
                    jq = order[l]
                    qj = Q[jq, 0] > 0.0
                    if qi or qj:
                        wq = -fw * r * h
                        ex = dx * ih  # (x_i - x_j) / h; P((x_j - x_i)/h) flips the linear terms
                        ey = dy * ih
                        p2 = ex * ex
                        p3 = ex * ey
                        p4 = ey * ey
                        rhoj = S[l, GRHO]
                        if qi:
                            s = wq * rhoi / rhoj
                            bgxi = s * (-Q[iq, 1] * ex - Q[iq, 2] * ey + Q[iq, 3] * p2 + Q[iq, 4] * p3 + Q[iq, 5] * p4)
                            bgyi = s * (-Q[iq, 6] * ex - Q[iq, 7] * ey + Q[iq, 8] * p2 + Q[iq, 9] * p3 + Q[iq, 10] * p4)
                        if qj:
                            s = -wq * rhoj / rhoi
                            bgxj = s * (Q[jq, 1] * ex + Q[jq, 2] * ey + Q[jq, 3] * p2 + Q[jq, 4] * p3 + Q[jq, 5] * p4)
                            bgyj = s * (Q[jq, 6] * ex + Q[jq, 7] * ey + Q[jq, 8] * p2 + Q[jq, 9] * p3 + Q[jq, 10] * p4)
                    pxj = S[l, GPXX]
                    pyj = S[l, GPYY]
                    pxyj = S[l, GPXY]
                    fx = pxi * bgxi + pxyi * bgyi + pxj * bgxj + pxyj * bgyj
                    fy = pxyi * bgxi + pyi * bgyi + pxyj * bgxj + pyj * bgyj
                    txx, tyy, txy, pij = pair_dissipation(
                        dx, dy, dvx, dvy, r, r2, gx, gy, ci + S[l, GCS], rhoi + S[l, GRHO], rxi + S[l, GRXX],
                        ryi + S[l, GRYY], rxyi + S[l, GRXY], h, alpha, beta, eta2, use_as, ras2, iwdp, nexp)
                    vx_, vy_, sx_, sy_ = dissipative_parts(txx, tyy, txy, pij, gx, gy)  # for the booking
                    avx += mj * vx_
                    avy += mj * vy_
                    asx += mj * sx_
                    asy += mj * sy_
                    A[t, l, A_VX] -= mi * vx_
                    A[t, l, A_VY] -= mi * vy_
                    A[t, l, A_SX] -= mi * sx_
                    A[t, l, A_SY] -= mi * sy_
                    fx += txx * gx + txy * gy
                    fy += txy * gx + tyy * gy
                    ax += mj * fx
                    ay += mj * fy
                    A[t, l, A_AX] -= mi * fx
                    A[t, l, A_AY] -= mi * fy
            A[t, k, A_AX] += ax
            A[t, k, A_AY] += ay
            A[t, k, A_VX] += avx
            A[t, k, A_VY] += avy
            A[t, k, A_SX] += asx
            A[t, k, A_SY] += asy
    sum_chunks(F, A, order, n_act)


