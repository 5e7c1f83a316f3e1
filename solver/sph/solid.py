"""Updated-Lagrangian solid SPH: the equations, one compiled kernel each.

Notation: particle i, neighbours j, m mass, rho density, v velocity, sigma Cauchy stress (tension
positive), grad_i W_ij the kernel gradient (:mod:`solver.sph.kernel`), v_ij = v_i - v_j.

* velocity gradient and continuity (Gray, Monaghan & Swift 2001, CMAME 190:6641, eqs. 2-3;
  Libersky & Petschek 1991; Monaghan 2005 eq. 3.7):
      (dv^a/dx^b)_i = (1 / rho_i) sum_j m_j (v_j - v_i)^a (grad_i W_ij)^b
      d rho_i / dt  = sum_j m_j v_ij . grad_i W_ij            ( = -rho_i tr L_i ),
  advanced as rho^{n+1} = rho^n exp(-tr L dt) (exact for constant L, positive for any dt), and a
  fully fractured (powder) particle's density floored at its solid density rho0 (grains separate,
  they do not dilate)
* hypoelastic stress with the Jaumann rate (Gray et al. 2001 eq. 8; LAMMPS SMD ulsph):
      d sigma / dt = (1 - D0) C(theta) : eps_dot + W sigma - sigma W,
      eps_dot = sym L, W = skew L, omega = W_yx = (L_yx - L_xy) / 2,
  with C the material-frame plane-strain stiffness rotated to the particle's material axis theta,
  and the axis rotating with the particle: d theta / dt = omega.
* damage after conversion (our law; the paper states only that damage keeps evolving until the
  material is fully fractured): while the largest principal stress is tensile, the largest
  principal strain rate accumulates kappa += max(eps_dot_1, 0) dt, d = min(1, kappa / kappa_f);
  the acting stress keeps the compressive principal parts and scales the tensile ones by (1 - d)
  (a tension-only damage as in LAMMPS SMD's Grady-Kipp-type models). At d = 1 the particle is a
  powder: no tension, the state stress is clipped to its compressive part.
* Monaghan artificial viscosity (Monaghan 1992 ARAA 30:543; Monaghan 2005 eq. 4.9):
      Pi_ij = (-alpha c_ij mu_ij + beta mu_ij^2) / rho_ij  if v_ij . r_ij < 0, else 0,
      mu_ij = h v_ij . r_ij / (r_ij^2 + 0.01 h^2), c_ij, rho_ij pair means.
* Gray-Monaghan-Swift artificial stress (Gray et al. 2001 eqs. 27-30; PySPH MonaghanArtificialStress):
  in the principal frame of sigma_i, R'_kk = -eps sigma'_kk / rho_i^2 if sigma'_kk > 0 else 0,
  rotated back; it enters the momentum equation as f_ij^n (R_i + R_j), f_ij = W(r_ij) / W(dp).
* momentum, symmetric form (Gray et al. 2001 eq. 1 with 26; Monaghan 2005 eq. 3.13):
      dv_i/dt = sum_j m_j (sigma_i/rho_i^2 B_i + sigma_j/rho_j^2 B_j + (f_ij^n (R_i + R_j) - Pi_ij I)) . grad_i W_ij
                + f_ext,i / m_i,
  B the first-order kernel-gradient correction (Randles & Libersky 1996; Bonet & Lok 1999), the
  identity when switched off or where the neighbourhood is too sparse to invert.
* energy booking (so the total is conserved up to the time-integration error of the stress):
  stress power (m_i/rho_i) sigma_i : eps_dot_i, from the constitutive update (the independent check
  of the momentum equation's stress forces); the viscous dissipation and the artificial stress's
  work as the work their parts of the force, a_v,i = -sum_j m_j Pi_ij grad_i W_ij and
  a_R,i = sum_j m_j f^n (R_i + R_j) . grad_i W_ij, do on the particle in each half-kick of the
  integrator, -m_i a . (v_before + v_after) dt / 4 (:mod:`solver.sph.loop`): exactly the kinetic
  energy they take. (Pair powers at the half-step velocity, 1/2 sum_j m_i m_j Pi_ij v_ij . grad_i W_ij,
  would not be: the kicks apply the forces at other velocities.)
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from .cells import NSTEN, build_cells, row_span, stencil
from .chunks import chunk_rows, clear_rows, sum_chunks
from .kernel import SUPPORT, gradw_factor, w_cubic
from .materials import M_C11, M_C12, M_C22, M_C66, M_CMAX, M_D0, M_KAPPA_F, M_RHO0
from .mls import W_ROWS, accumulate, quadratic_gradient, transposed_weights
from .particles import (ASX, ASY, AVX, AVY, AX, AY, BXX, BXY, BYX, BYY, CS, DMG, ESXX, ESXY, ESYY, EST, FXE, FXT, FYE, FYT,
                        GBXX, GBXY, GBYX, GBYY, GCS, GM, GPXX, GPXY, GPYY, GRHO, GRXX, GRXY, GRYY, GVX, GVY, GX, GY,
                        KAPPA, LXX, LXY, LYX, LYY, M, MAT, P_ALPHA, P_BETA, P_EPS, P_H, P_NEXP, P_WDP, RHO, RMIN,
                        RXX, RXY, RYY, SXX, SXY, SYY, THETA, VX, VY, X, Y)

#: fast-math flags for the pair loops: reassociation and reciprocal approximations, but NaN and inf
#: keep their IEEE meaning (the stability guard relies on them).
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}

#: smallest singular value of the moment matrix M for which the kernel gradient is corrected
#: (:func:`velocity_gradient`)
SMIN_CORR = 0.2


#: (cell-order column of S, row of F) of the particle data :func:`gather_kinematics` and :func:`gather_stress`
#: copy as they are
KINEMATIC_COLUMNS = np.array([[GX, X], [GY, Y], [GVX, VX], [GVY, VY], [GM, M], [GRHO, RHO]], dtype=np.int64)
STRESS_COLUMNS = np.array([[GRHO, RHO], [GRXX, RXX], [GRYY, RYY], [GRXY, RXY], [GCS, CS], [GBXX, BXX], [GBXY, BXY],
                           [GBYX, BYX], [GBYY, BYY]], dtype=np.int64)


@numba.njit(cache=True, inline="always")
def copy_columns(F, S, i, k, columns):
    """S[k, c] = F[r, i] for the (c, r) rows of ``columns``: particle i's data into cell-order row k."""
    for q in range(columns.shape[0]):
        S[k, columns[q, 0]] = F[columns[q, 1], i]


@numba.njit(parallel=True, cache=True)
def gather_kinematics(F, S, order, n_act):
    """Copy position, velocity, mass and density of the active particles into cell order (S[k, G*])."""
    for k in prange(n_act):
        copy_columns(F, S, order[k], k, KINEMATIC_COLUMNS)


@numba.njit(parallel=True, cache=True)
def gather_stress(F, S, order, n_act):
    """Copy sigma/rho^2, the artificial stress R, the sound speed and the gradient correction B into cell
    order (S[k, G*])."""
    for k in prange(n_act):
        i = order[k]
        r2 = 1.0 / (F[RHO, i] * F[RHO, i])
        S[k, GPXX] = F[ESXX, i] * r2
        S[k, GPYY] = F[ESYY, i] * r2
        S[k, GPXY] = F[ESXY, i] * r2
        copy_columns(F, S, i, k, STRESS_COLUMNS)


#: columns of the momentum pass's pair accumulators (:func:`pair_buffers`)
A_AX, A_AY, A_VX, A_VY, A_SX, A_SY = range(6)
NA = 6


def pair_buffers(n: int, n_chunks: int) -> np.ndarray:
    """Per-chunk accumulators of the symmetric pair loop of :func:`momentum`, shape (n_chunks, n, NA)."""
    return np.zeros((max(1, n_chunks), n, NA))


@numba.njit(cache=True, inline="always")
def kinematics(S, k):
    """Position and velocity of particle k (cell order)."""
    return S[k, GX], S[k, GY], S[k, GVX], S[k, GVY]


@numba.njit(cache=True, inline="always")
def separation(xi, yi, S, l):
    """x_ij = x_i - x_l and r_ij^2 of particle l (cell order) seen from the point (xi, yi)."""
    dx = xi - S[l, GX]
    dy = yi - S[l, GY]
    return dx, dy, dx * dx + dy * dy


@numba.njit(cache=True, inline="always")
def kernel_gradient(r2, h, dx, dy):
    """r_ij, the kernel factor F = (dW/dr) / r and grad_i W_ij = F x_ij of the 2D cubic spline
    (Monaghan 2005 eq. 2.6, :func:`solver.sph.kernel.gradw_factor`) from x_ij = (dx, dy), r_ij^2 = r2."""
    r = math.sqrt(r2)
    fw = gradw_factor(r, h)
    return r, fw, fw * dx, fw * dy


@numba.njit(cache=True, inline="always")
def pair_outer(m, ax, ay, gx, gy):
    """m a (x) g row-major (xx, xy, yx, yy): the pair term of the velocity gradient,
    rho_i (dv^a/dx^b)_i = sum_j m_j v_ji^a g^b (Gray et al. 2001 eq. 2; Libersky & Petschek 1991), with
    a = v_ji, and of the moment matrix of the kernel-gradient correction,
    rho_i M_i = -sum_j m_j x_ij (x) g (Randles & Libersky 1996; Bonet & Lok 1999), with a = x_ij;
    g = grad_i W_ij."""
    return m * ax * gx, m * ax * gy, m * ay * gx, m * ay * gy


@numba.njit(cache=True, inline="always")
def corrected_gradient(bxx, bxy, byx, byy, gx, gy):
    """B g, the first-order corrected kernel gradient (Randles & Libersky 1996; Bonet & Lok 1999)."""
    return bxx * gx + bxy * gy, byx * gx + byy * gy


@numba.njit(cache=True, inline="always")
def stress_term(pxi, pyi, pxyi, bgxi, bgyi, pxj, pyj, pxyj, bgxj, bgyj):
    """sigma_i/rho_i^2 . B_i g + sigma_j/rho_j^2 . B_j g (Gray et al. 2001 eq. 1 with the corrected
    gradients of Bonet & Lok 1999), P = sigma/rho^2 as (xx, yy, xy)."""
    return (pxi * bgxi + pxyi * bgyi + pxj * bgxj + pxyj * bgyj,
            pxyi * bgxi + pyi * bgyi + pxyj * bgxj + pyj * bgyj)


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def velocity_gradient_pass(F, S, Q, order, n_act, start, ncx, ncy, x0, y0, cell, h, corrected, smax):
    """Velocity gradient L_i = (1/rho_i) sum_j m_j (v_j - v_i) (x) B_i grad_i W_ij (Gray et al. 2001
    eq. 2; Monaghan 2005 eq. 3.7), whose trace drives the continuity d rho_i/dt = -rho_i tr L_i (eq. 3)
    in :func:`update_state`.

    With ``corrected`` the kernel gradient is renormalised, B_i = M_i^-T,
    M_i = (1/rho_i) sum_j m_j (x_j - x_i) (x) grad_i W_ij, so that a linear velocity field gives its
    exact gradient also at free surfaces (Randles & Libersky 1996, CMAME 139:375; Bonet & Lok 1999,
    CMAME 180:97). M_i is inverted wherever its smallest singular value is at least ``SMIN_CORR``
    (0.2: the correction amplifies the raw gradient at most fivefold): a full neighbourhood has 1, a
    flat free surface 0.5, a right-angled corner of a lattice 0.27 (h = 1.3 dp), so every particle of
    a compact body is corrected; near-collinear neighbourhoods (isolated particles, chains, fragments)
    keep B_i = I. Without ``corrected`` B_i = I. (The former test det M > 0.25 left the corners of a
    body uncorrected, where the raw gradient L = grad(v) M is not objective: a rigid rotation strained
    them.) Also the nearest-neighbour distance RMIN (clumping check).

    Q (float64[n, NQ]; None: off) switches on the quadratic-complete surface gradient of
    :mod:`solver.sph.quadratic` (Lancaster & Salkauskas 1981; Belytschko et al. 1996): B_i is then
    always computed, and where the support is cut (smallest singular value of M_i below ``smax``, and
    at least SMIN_CORR) L_i is the moving-least-squares gradient
    L_i = sum_j (v_j - v_i) (x) V_j omega_ij C_i P(e_ij), omega_ij = -h r_ij W'(r_ij)
    (:mod:`solver.sph.mls`), and Q[i] = (1, C_i); elsewhere Q[i, 0] = 0.
    Writes LXX, LXY, LYX, LYY, RMIN, BXX, BXY, BYX, BYY (update_state advances rho from tr L)."""
    rc2 = 4.0 * h * h
    ih = 1.0 / h
    if Q is not None:  # (numba compiles the Q-less call without any of the quadratic branches)
        corrected = True
    for k in prange(n_act):
        i = order[k]
        xi, yi, vxi, vyi = kinematics(S, k)
        cy, lo_x, hi_x, lo_y, end_y = stencil(xi, yi, x0, y0, cell, ncx, ncy)
        lxx = lxy = lyx = lyy = 0.0
        mxx = mxy = myx = myy = 0.0
        if Q is not None:
            W = np.zeros((W_ROWS, 5))
        rmin2 = math.inf
        for ny in range(lo_y, end_y):
            l0, l1 = row_span(start, ncx, ny, lo_x, hi_x)
            for l in range(l0, l1):
                dx, dy, r2 = separation(xi, yi, S, l)
                if r2 >= rc2 or l == k:
                    continue
                if r2 < rmin2:
                    rmin2 = r2
                r, fw, gx, gy = kernel_gradient(r2, h, dx, dy)
                mj = S[l, GM]
                dvx = S[l, GVX] - vxi
                dvy = S[l, GVY] - vyi
                txx, txy, tyx, tyy = pair_outer(mj, dvx, dvy, gx, gy)
                lxx += txx
                lxy += txy
                lyx += tyx
                lyy += tyy
                txx, txy, tyx, tyy = pair_outer(mj, dx, dy, gx, gy)
                mxx -= txx
                mxy -= txy
                myx -= tyx
                myy -= tyy
                if Q is not None:
                    accumulate(W, -mj / S[l, GRHO] * fw * r * h, -dx * ih, -dy * ih, dvx, dvy)
        ir = 1.0 / S[k, GRHO]
        bxx = 1.0
        bxy = 0.0
        byx = 0.0
        byy = 1.0
        det = 0.0
        smin2 = 0.0
        if corrected:
            mxx *= ir
            mxy *= ir
            myx *= ir
            myy *= ir
            det = mxx * myy - mxy * myx
            # smallest singular value of M: s_min^2 = (|M|^2 - sqrt(|M|^4 - 4 det^2)) / 2
            fro = mxx * mxx + mxy * mxy + myx * myx + myy * myy
            disc = max(fro * fro - 4.0 * det * det, 0.0)
            smin2 = 0.5 * (fro - math.sqrt(disc))
            if det > 0.0 and smin2 > SMIN_CORR * SMIN_CORR:
                idet = 1.0 / det
                # B = M^-T
                bxx = myy * idet
                bxy = -myx * idet
                byx = -mxy * idet
                byy = mxx * idet
        lxx *= ir
        lxy *= ir
        lyx *= ir
        lyy *= ir
        # L = raw . B^T  (raw_ac B_bc)
        F[LXX, i] = lxx * bxx + lxy * bxy
        F[LXY, i] = lxx * byx + lxy * byy
        F[LYX, i] = lyx * bxx + lyy * bxy
        F[LYY, i] = lyx * byx + lyy * byy
        F[BXX, i] = bxx
        F[BXY, i] = bxy
        F[BYX, i] = byx
        F[BYY, i] = byy
        F[RMIN, i] = math.sqrt(rmin2)
        if Q is not None:
            Q[i, 0] = 0.0
            if det > 0.0 and SMIN_CORR * SMIN_CORR < smin2 < smax * smax:
                ok, gxx, gxy, gyx, gyy = quadratic_gradient(W, Q, i, ih)
                if ok:
                    F[LXX, i] = gxx
                    F[LXY, i] = gxy
                    F[LYX, i] = gyx
                    F[LYY, i] = gyy


@numba.njit(cache=True)
def velocity_gradient(F, S, order, n_act, start, ncx, ncy, x0, y0, cell, h, corrected):
    """:func:`velocity_gradient_pass` in its first-order form (Gray et al. 2001 eq. 2 with B_i of
    Randles & Libersky 1996 / Bonet & Lok 1999 where ``corrected``): no quadratic rows."""
    velocity_gradient_pass(F, S, None, order, n_act, start, ncx, ncy, x0, y0, cell, h, corrected, 0.0)


@numba.njit(cache=True, inline="always")
def principal(sxx, syy, sxy):
    """Principal values s1 >= s2 of a symmetric 2x2 tensor (xx, yy, xy)."""
    c = 0.5 * (sxx + syy)
    d = 0.5 * (sxx - syy)
    rad = math.sqrt(d * d + sxy * sxy)
    return c + rad, c - rad


@numba.njit(cache=True, inline="always")
def spectral_map(sxx, syy, sxy, s1, s2, t1, t2):
    """The tensor with the principal axes of (sxx, syy, sxy) (principal values s1 >= s2) and the
    principal values t1, t2: t2 I + (t1 - t2) P1, with P1 = (sigma - s2 I) / (s1 - s2) the projector
    on the s1 axis (no angles, no trigonometry). A tensor with equal principal values has no axes:
    it maps to the mean of t1 and t2 times I."""
    rad = s1 - s2
    if rad <= 1e-14 * (abs(s1) + abs(s2)) or rad == 0.0:
        m = 0.5 * (t1 + t2)
        return m, m, 0.0
    f = (t1 - t2) / rad
    return t2 + f * (sxx - s2), t2 + f * (syy - s2), f * sxy


@numba.njit(parallel=True, cache=True)
def update_state(F, I, act, n_act, mats, prm, dt):
    """Advance density, stress, material axis and damage of the active particles by dt from L;
    then the effective stress, the artificial stress R (Gray et al. 2001 eqs. 27-30), the sound speed
    and the stress work. Equations in the module docstring (Jaumann rate: Gray et al. 2001 eq. 8)."""
    eps_as = prm[P_EPS]
    for k in prange(n_act):
        i = act[k]
        mat = I[MAT, i]
        rho_old = F[RHO, i]
        # continuity d rho/dt = -rho tr L integrated exactly over the step for constant L: the density
        # stays positive whatever the step (rho + dt drho/dt goes negative once tr L dt > 1)
        rho = rho_old * math.exp(-(F[LXX, i] + F[LYY, i]) * dt)
        if F[DMG, i] >= 1.0 and rho < mats[mat, M_RHO0]:
            # a fully fractured particle is a powder grain: grains moving apart open gaps between
            # them, they do not dilate (and no tension acts to resist it), so the grain's density
            # does not fall below the solid's; without this floor a dispersing powder cloud has
            # rho -> 0 and a sound speed sqrt(C / rho) -> inf (the full d08 scene's blow-up)
            rho = mats[mat, M_RHO0]
        F[RHO, i] = rho
        lxx = F[LXX, i]
        lxy = F[LXY, i]
        lyx = F[LYX, i]
        lyy = F[LYY, i]
        exx = lxx
        eyy = lyy
        exy = 0.5 * (lxy + lyx)
        w = 0.5 * (lyx - lxy)
        fac = 1.0 - mats[mat, M_D0]
        th = F[THETA, i] + 0.5 * dt * w
        co = math.cos(th)
        si = math.sin(th)
        cc = co * co
        ss = si * si
        cs_ = co * si
        # strain rate in the material frame
        e11 = cc * exx + ss * eyy + 2.0 * cs_ * exy
        e22 = ss * exx + cc * eyy - 2.0 * cs_ * exy
        e12 = -cs_ * exx + cs_ * eyy + (cc - ss) * exy
        s11 = fac * (mats[mat, M_C11] * e11 + mats[mat, M_C12] * e22)
        s22 = fac * (mats[mat, M_C12] * e11 + mats[mat, M_C22] * e22)
        s12 = fac * 2.0 * mats[mat, M_C66] * e12
        # back to the global frame, plus the Jaumann spin terms W sigma - sigma W
        sxx = F[SXX, i]
        syy = F[SYY, i]
        sxy = F[SXY, i]
        dsxx = cc * s11 + ss * s22 - 2.0 * cs_ * s12 - 2.0 * w * sxy
        dsyy = ss * s11 + cc * s22 + 2.0 * cs_ * s12 + 2.0 * w * sxy
        dsxy = cs_ * s11 - cs_ * s22 + (cc - ss) * s12 + w * (sxx - syy)
        sxx += dt * dsxx
        syy += dt * dsyy
        sxy += dt * dsxy
        F[THETA, i] += dt * w
        # tensile damage growth after conversion
        d = F[DMG, i]
        kf = mats[mat, M_KAPPA_F]
        s1, s2 = principal(sxx, syy, sxy)
        if d < 1.0 and kf < 1e300 and s1 > 0.0:
            e1, e2 = principal(exx, eyy, exy)
            if e1 > 0.0:
                F[KAPPA, i] += dt * e1
                d = min(1.0, F[KAPPA, i] / kf)
                F[DMG, i] = d
        if d > 0.0 and s1 > 0.0:
            t1 = s1 * (1.0 - d)
            t2 = s2 * (1.0 - d) if s2 > 0.0 else s2
            esxx, esyy, esxy = spectral_map(sxx, syy, sxy, s1, s2, t1, t2)
            if d >= 1.0:  # powder: the state forgets its tension
                sxx = esxx
                syy = esyy
                sxy = esxy
        else:
            esxx = sxx
            esyy = syy
            esxy = sxy
        F[SXX, i] = sxx
        F[SYY, i] = syy
        F[SXY, i] = sxy
        # stress work (trapezoid in the acting stress), per unit width
        vol = F[M, i] / (0.5 * (rho + rho_old))
        F[EST, i] += dt * vol * 0.5 * ((F[ESXX, i] + esxx) * exx + (F[ESYY, i] + esyy) * eyy
                                       + 2.0 * (F[ESXY, i] + esxy) * exy)
        F[ESXX, i] = esxx
        F[ESYY, i] = esyy
        F[ESXY, i] = esxy
        # Gray-Monaghan-Swift artificial stress from the acting stress
        if eps_as > 0.0:
            p1, p2 = principal(esxx, esyy, esxy)
            rxx = 0.0
            ryy = 0.0
            rxy = 0.0
            if p1 > 0.0:  # R acts only against tension
                ir2 = 1.0 / (rho * rho)
                r2 = -eps_as * p2 * ir2 if p2 > 0.0 else 0.0
                rxx, ryy, rxy = spectral_map(esxx, esyy, esxy, p1, p2, -eps_as * p1 * ir2, r2)
            F[RXX, i] = rxx
            F[RYY, i] = ryy
            F[RXY, i] = rxy
        F[CS, i] = math.sqrt(mats[mat, M_CMAX] * fac / rho)


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def momentum_pass(F, I, S, A, Q, order, n_act, start, ncx, ncy, x0, y0, cell, prm):
    """Acceleration dv_i/dt = sum_j m_j (sigma_i/rho_i^2 + sigma_j/rho_j^2 + f^n (R_i + R_j) - Pi_ij I)
    . grad_i W_ij + (f_ext + f_tool)/m (Gray et al. 2001 eqs. 1, 26; Monaghan 2005 eqs. 3.13, 4.9), the stress
    terms with the corrected gradients B_i grad_i W_ij, B_j grad_i W_ij (antisymmetric in i, j, so
    momentum is conserved; Bonet & Lok 1999) and consistent with the stress power of
    :func:`velocity_gradient`. Keeps the viscous and the artificial-stress parts of the acceleration
    apart (AVX, AVY and ASX, ASY), for the kicks' booking of their work (:mod:`solver.sph.loop`).

    Each pair is visited once: with X_ij the bracket above dotted into grad_i W_ij (antisymmetric:
    X_ji = -X_ij), i gains m_j X_ij and j loses m_i X_ij (so also the viscous and artificial-stress
    parts). The half stencil of particle k (in cell order): the rest of
    its own cell row from k + 1 on, and the full stencil rows above (the rows below hold only
    earlier particles). The particles are split into contiguous chunks of the cell order; chunk t
    adds into its own accumulator A[t] (:func:`pair_buffers`), so threads never write to the same
    memory, and a second pass (:func:`finish_momentum`) sums the chunks in a fixed order: the result
    does not depend on how many threads run (:mod:`solver.sph.chunks`).  (Half the pair work of the full stencil: 1.8x faster at 1e5 particles.)

    Q (float64[n, NQ]; None: off): the particles with Q[i, 0] > 0 carry the quadratic-complete
    gradient of :func:`velocity_gradient_pass` (:mod:`solver.sph.quadratic`); their stress term is
    the transpose of that gradient (:func:`solver.sph.mls.transposed_weights`), so that the stress
    power is exactly sum_i V_i sigma_i : L_i (Bonet & Lok 1999 sec. 3; Belytschko et al. 1998 IJNME
    43:785): q_ij = V_i sigma_i . V_j omega_ij C_i P((x_j - x_i)/h) in place of
    m_i m_j sigma_i/rho_i^2 . B_i grad_i W_ij."""
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
        k0, k1 = chunk_rows(t, n_act, n_chunks)
        clear_rows(A, t, k0, n_act, NA)
        for k in range(k0, k1):
            xi, yi, vxi, vyi = kinematics(S, k)
            mi = S[k, GM]
            pxi, pyi, pxyi = S[k, GPXX], S[k, GPYY], S[k, GPXY]  # sigma_i / rho_i^2
            rxi, ryi, rxyi = S[k, GRXX], S[k, GRYY], S[k, GRXY]  # R_i
            ci = S[k, GCS]
            rhoi = S[k, GRHO]
            bxxi, bxyi, byxi, byyi = S[k, GBXX], S[k, GBXY], S[k, GBYX], S[k, GBYY]  # B_i
            iq = order[k]
            qi = False
            if Q is not None:
                qi = Q[iq, 0] > 0.0
            cy, lo_x, hi_x, lo_y, end_y = stencil(xi, yi, x0, y0, cell, ncx, ncy)
            ax = ay = avx = avy = asx = asy = 0.0
            for ny in range(cy, end_y):
                l0, l1 = row_span(start, ncx, ny, lo_x, hi_x)
                if ny == cy:
                    l0 = k + 1
                for l in range(l0, l1):
                    dx, dy, r2 = separation(xi, yi, S, l)
                    if r2 >= rc2:
                        continue
                    r, fw, gx, gy = kernel_gradient(r2, h, dx, dy)
                    mj = S[l, GM]
                    dvx = vxi - S[l, GVX]
                    dvy = vyi - S[l, GVY]
                    bgxi, bgyi = corrected_gradient(bxxi, bxyi, byxi, byyi, gx, gy)
                    bgxj, bgyj = corrected_gradient(S[l, GBXX], S[l, GBXY], S[l, GBYX], S[l, GBYY], gx, gy)
                    if Q is not None:
                        jq = order[l]
                        qj = Q[jq, 0] > 0.0
                        if qi or qj:
                            bgxi, bgyi, bgxj, bgyj = transposed_weights(Q, iq, jq, qi, qj, -fw * r * h, dx, dy, ih, rhoi,
                                                                        S[l, GRHO], bgxi, bgyi, bgxj, bgyj)
                    fx, fy = stress_term(pxi, pyi, pxyi, bgxi, bgyi, S[l, GPXX], S[l, GPYY], S[l, GPXY], bgxj, bgyj)
                    txx, tyy, txy, pij = pair_dissipation(
                        dx, dy, dvx, dvy, r, r2, gx, gy, ci + S[l, GCS], rhoi + S[l, GRHO], rxi + S[l, GRXX],
                        ryi + S[l, GRYY], rxyi + S[l, GRXY], h, alpha, beta, eta2, use_as, ras2, iwdp, nexp)
                    vx_, vy_, sx_, sy_ = dissipative_parts(txx, tyy, txy, pij, gx, gy)  # for the booking
                    fx += txx * gx + txy * gy
                    fy += txy * gx + tyy * gy
                    ax += mj * fx
                    ay += mj * fy
                    avx += mj * vx_
                    avy += mj * vy_
                    asx += mj * sx_
                    asy += mj * sy_
                    X = (fx, fy, vx_, vy_, sx_, sy_)  # columns A_AX .. A_SY; odd: l loses m_i X
                    for q in range(NA):
                        A[t, l, q] -= mi * X[q]
            own = (ax, ay, avx, avy, asx, asy)
            for q in range(NA):
                A[t, k, q] += own[q]
    finish_momentum(F, A, order, n_act)


@numba.njit(cache=True)
def momentum(F, I, S, A, order, n_act, start, ncx, ncy, x0, y0, cell, prm):
    """:func:`momentum_pass` with the first-order corrected gradients B_i grad_i W_ij only (Gray et
    al. 2001 eqs. 1, 26; Monaghan 2005 eqs. 3.13, 4.9): no quadratic rows."""
    momentum_pass(F, I, S, A, None, order, n_act, start, ncx, ncy, x0, y0, cell, prm)


@numba.njit(cache=True)
def artificial_stress_reach2(h, iwdp, nexp):
    """Squared distance beyond which the artificial-stress weight f^n = (W(r) / W(dp))^n falls below
    1e-6 (W falls monotonically: bisection on r); :func:`momentum` skips the term beyond it."""
    lo = 0.0
    hi = 2.0 * h
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if (w_cubic(mid, h) * iwdp) ** nexp > 1e-6:
            lo = mid
        else:
            hi = mid
    return hi * hi


@numba.njit(cache=True, inline="always")
def pair_dissipation(dx, dy, dvx, dvy, r, r2, gx, gy, c_sum, rho_sum, rxx_sum, ryy_sum, rxy_sum, h, alpha, beta, eta2,
                     use_as, ras2, iwdp, nexp):
    """The pair's tensor T = f^n (R_i + R_j) - Pi_ij I of the momentum equation, and Pi_ij: Monaghan's
    viscosity Pi_ij = (-alpha c_ij mu_ij + beta mu_ij^2) / rho_ij for approaching pairs,
    mu_ij = h v_ij . r_ij / (r_ij^2 + 0.01 h^2) (Monaghan 1992; 2005 eq. 4.9), and Gray et al.'s
    (2001 eqs. 27-30) artificial stress with f = W(r) / W(dp). ``c_sum``, ``rho_sum`` and the R sums
    are the pair's sums (i + j). Returns (txx, tyy, txy, Pi_ij)."""
    txx = 0.0
    tyy = 0.0
    txy = 0.0
    pij = 0.0
    vdr = dvx * dx + dvy * dy
    if vdr < 0.0:
        mu = h * vdr / (r2 + eta2)
        pij = (-alpha * 0.5 * c_sum * mu + beta * mu * mu) / (0.5 * rho_sum)
        txx -= pij
        tyy -= pij
    if use_as and r2 < ras2 and (rxx_sum != 0.0 or ryy_sum != 0.0 or rxy_sum != 0.0):
        f = w_cubic(r, h) * iwdp
        fn = f
        for _ in range(nexp - 1):
            fn *= f
        txx += fn * rxx_sum
        tyy += fn * ryy_sum
        txy += fn * rxy_sum
    return txx, tyy, txy, pij


@numba.njit(cache=True, inline="always")
def dissipative_parts(txx, tyy, txy, pij, gx, gy):
    """The viscous and the artificial-stress parts of a pair's T . g (:func:`pair_dissipation`'s
    T = f^n (R_i + R_j) - Pi_ij I and Pi_ij), kept apart for the kicks' booking of their work:
    -Pi_ij g and (T + Pi_ij I) . g, as (vx, vy, sx, sy)."""
    return -pij * gx, -pij * gy, (txx + pij) * gx + txy * gy, txy * gx + (tyy + pij) * gy


@numba.njit(parallel=True, cache=True)
def finish_momentum(F, A, order, n_act):
    """Second pass of the symmetric pair loop: particle order[k]'s acceleration is the sum of its
    chunk accumulators A[t, k] in the fixed order t = 0, 1, ... (:func:`solver.sph.chunks.sum_chunks`,
    independent of the thread count), plus the external and tool forces over its mass; its viscous and
    artificial-stress parts go to AVX, AVY and ASX, ASY (the kicks book their work, :mod:`solver.sph.loop`)."""
    for k in prange(n_act):
        sum_chunks(A, k, n_act, NA)
        i = order[k]
        mi = F[M, i]
        F[AX, i] = A[0, k, A_AX] + (F[FXE, i] + F[FXT, i]) / mi
        F[AY, i] = A[0, k, A_AY] + (F[FYE, i] + F[FYT, i]) / mi
        F[AVX, i] = A[0, k, A_VX]
        F[AVY, i] = A[0, k, A_VY]
        F[ASX, i] = A[0, k, A_SX]
        F[ASY, i] = A[0, k, A_SY]


@numba.njit(cache=True)
def refresh_for_forces(F, I, S, act, n_act, mats, prm, order, cell_of):
    """What a momentum pass needs of the current state, outside the step: the cell list, the acting
    and artificial stress (update_state with dt = 0) and the gathered rows. Returns build_cells'
    (start, ncx, ncy, x0, y0, cell, ok)."""
    cells = build_cells(F[X], F[Y], act, n_act, SUPPORT * prm[P_H] / NSTEN, order, cell_of)
    if cells[6]:
        update_state(F, I, act, n_act, mats, prm, 0.0)
        gather_kinematics(F, S, order, n_act)
        gather_stress(F, S, order, n_act)
    return cells

@numba.njit(cache=True)
def signal_dt(F, act, n_act, h):
    """Signal-speed time step min_i h / (c_i + |v_i|) over the active particles (Monaghan 2005 sec. 6)."""
    dt = math.inf
    for k in range(n_act):
        i = act[k]
        v = math.sqrt(F[VX, i] * F[VX, i] + F[VY, i] * F[VY, i])
        d = h / (F[CS, i] + v)
        if d < dt:
            dt = d
    return dt
