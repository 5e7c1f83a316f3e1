"""Updated-Lagrangian solid SPH in 3D: the equations of :mod:`solver.sph.solid`, one compiled kernel each.

Notation: particle i, neighbours j, m mass, rho density, v velocity, sigma Cauchy stress (tension
positive, Voigt order xx, yy, zz, xy, yz, zx), grad_i W_ij the 3D kernel gradient
(:mod:`solver.sph3d.kernel`), v_ij = v_i - v_j.

* velocity gradient and continuity (Gray, Monaghan & Swift 2001, CMAME 190:6641, eqs. 2-3;
  Libersky & Petschek 1991; Monaghan 2005 eq. 3.7):
      (dv^a/dx^b)_i = (1 / rho_i) sum_j m_j (v_j - v_i)^a (B_i grad_i W_ij)^b
      d rho_i / dt  = -rho_i tr L_i,   advanced as rho^{n+1} = rho^n exp(-tr L dt)
  with B_i = M_i^-T, M_i = (1/rho_i) sum_j m_j (x_j - x_i) (x) grad_i W_ij, the first-order
  kernel-gradient correction (Randles & Libersky 1996, CMAME 139:375; Bonet & Lok 1999, CMAME
  180:97), applied where det M_i > 0 and the smallest singular value of M_i is at least SMIN_CORR
  (0.2, as 2D), B_i = I elsewhere or when switched off;
* hypoelastic stress with the Jaumann rate (Gray et al. 2001 eq. 8):
      d sigma / dt = (1 - D0) (lambda tr(eps_dot) I + 2 G eps_dot) + Omega sigma - sigma Omega,
      eps_dot = sym L, Omega = skew L = (L - L^T) / 2,
  isotropic (lambda = C12, G = C66 of the 2D material row, :mod:`solver.sph3d.particles`); the 2D
  engine's elastic law, with its tensile damage growth after conversion not carried over (the
  stiffness reduction D0 is);
* Monaghan artificial viscosity (Monaghan 1992 ARAA 30:543; Monaghan 2005 eq. 4.9):
      Pi_ij = (-alpha c_ij mu_ij + beta mu_ij^2) / rho_ij  if v_ij . r_ij < 0, else 0,
      mu_ij = h v_ij . r_ij / (r_ij^2 + 0.01 h^2), c_ij, rho_ij pair means;
* Gray-Monaghan-Swift artificial stress (Gray et al. 2001 eqs. 27-30): in the principal frame of
  sigma_i, R'_kk = -eps sigma'_kk / rho_i^2 if sigma'_kk > 0 else 0, rotated back (by the spectral
  projectors of sigma, :func:`spectral_map3`: no eigenvectors); it enters the momentum equation as
  f_ij^n (R_i + R_j), f_ij = W(r_ij) / W(dp);
* momentum (Gray et al. 2001 eq. 1 with 26; Monaghan 2005 eq. 3.13):
      dv_i/dt = sum_j m_j (sigma_i/rho_i^2 B_i + sigma_j/rho_j^2 B_j + f_ij^n (R_i + R_j) - Pi_ij I) . grad_i W_ij
                + (walls) ,
  antisymmetric in i, j (momentum conserved to round-off); its viscous and artificial-stress parts
  are kept apart for the kicks' booking of their work (:mod:`solver.sph3d.loop`);
* stress work: (m_i / rho_i) sigma_i : eps_dot_i dt, trapezoidal in sigma (as 2D).

The pair loops run over a neighbour list built in the velocity-gradient pass (one row of up to
``cap`` neighbours per particle, in cell order; the chunk driver enlarges it when a particle has
more), so the candidate search of the cell stencil is paid once per step.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from ..sph.materials import M_C12, M_C66, M_CMAX, M_D0
from .kernel import gradw_factor3, w_cubic3
from .particles import (GB0, GB1, GB2, GB3, GB4, GB5, GB6, GB7, GB8, GCS, GM, GP0, GP1, GP2, GP3, GP4, GP5, GR0, GR1,
                        GR2, GR3, GR4, GR5, GRHO, GVX, GVY, GVZ, GX, GY, GZ)
from .walls import wall_accel

#: fast-math flags of the pair loops (as 2D: NaN and inf keep their IEEE meaning)
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
#: smallest singular value of M_i for which the kernel gradient is corrected (as 2D)
SMIN_CORR = 0.2


@numba.njit(cache=True, inline="always")
def sym_eig3(a00, a11, a22, a01, a12, a02):
    """Eigenvalues e1 >= e2 >= e3 of a symmetric 3x3 matrix, in closed form (Smith 1961, CACM 4:168:
    the trigonometric solution of the characteristic cubic)."""
    p1 = a01 * a01 + a12 * a12 + a02 * a02
    q = (a00 + a11 + a22) / 3.0
    b00 = a00 - q
    b11 = a11 - q
    b22 = a22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    if p2 <= 0.0:
        return q, q, q
    p = math.sqrt(p2 / 6.0)
    ip = 1.0 / p
    c00 = b00 * ip
    c11 = b11 * ip
    c22 = b22 * ip
    c01 = a01 * ip
    c12 = a12 * ip
    c02 = a02 * ip
    r = 0.5 * (c00 * (c11 * c22 - c12 * c12) - c01 * (c01 * c22 - c12 * c02) + c02 * (c01 * c12 - c11 * c02))
    if r <= -1.0:
        phi = math.pi / 3.0
    elif r >= 1.0:
        phi = 0.0
    else:
        phi = math.acos(r) / 3.0
    e1 = q + 2.0 * p * math.cos(phi)
    e3 = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    e2 = 3.0 * q - e1 - e3
    return e1, e2, e3


@numba.njit(cache=True, inline="always")
def spectral_map3(s0, s1, s2, s3, s4, s5, e1, e2, e3, t1, t2, t3):
    """The tensor with the principal axes of s (Voigt xx, yy, zz, xy, yz, zx; eigenvalues e1 >= e2 >= e3)
    and the principal values t1, t2, t3: sum_k t_k P_k with the spectral projectors
    P_k = prod_{l != k} (s - e_l I) / (e_k - e_l) (Sylvester's formula; the 3D form of 2D's
    :func:`solver.sph.solid.spectral_map`). Eigenvalues closer than 1e-4 of their scale are merged
    (their projector pair is I minus the third's; their values averaged), and all three when all are."""
    scale = abs(e1) + abs(e2) + abs(e3)
    tol = 1e-4 * scale
    g12 = e1 - e2
    g23 = e2 - e3
    if scale == 0.0 or (g12 <= tol and g23 <= tol):
        m = (t1 + t2 + t3) / 3.0
        return m, m, m, 0.0, 0.0, 0.0
    if g12 <= tol or g23 <= tol:
        if g12 <= tol:  # e1 = e2: the single axis is e3's
            mu = 0.5 * (e1 + e2)
            ta = 0.5 * (t1 + t2)
            tb = t3
            eb = e3
        else:  # e2 = e3: the single axis is e1's
            mu = 0.5 * (e2 + e3)
            ta = 0.5 * (t2 + t3)
            tb = t1
            eb = e1
        f = (tb - ta) / (eb - mu)  # ta I + (tb - ta) (s - mu I) / (eb - mu)
        return ta + f * (s0 - mu), ta + f * (s1 - mu), ta + f * (s2 - mu), f * s3, f * s4, f * s5
    # s^2 (symmetric)
    q0 = s0 * s0 + s3 * s3 + s5 * s5
    q1 = s3 * s3 + s1 * s1 + s4 * s4
    q2 = s5 * s5 + s4 * s4 + s2 * s2
    q3 = s0 * s3 + s3 * s1 + s5 * s4
    q4 = s3 * s5 + s1 * s4 + s4 * s2
    q5 = s0 * s5 + s3 * s4 + s5 * s2
    # sum_k t_k [s^2 - (e_a + e_b) s + e_a e_b I] / ((e_k - e_a)(e_k - e_b)) = A s^2 + Bc s + C I
    c1 = t1 / ((e1 - e2) * (e1 - e3))
    c2 = t2 / ((e2 - e1) * (e2 - e3))
    c3 = t3 / ((e3 - e1) * (e3 - e2))
    A = c1 + c2 + c3
    Bc = -(c1 * (e2 + e3) + c2 * (e1 + e3) + c3 * (e1 + e2))
    C = c1 * e2 * e3 + c2 * e1 * e3 + c3 * e1 * e2
    return (A * q0 + Bc * s0 + C, A * q1 + Bc * s1 + C, A * q2 + Bc * s2 + C, A * q3 + Bc * s3, A * q4 + Bc * s4,
            A * q5 + Bc * s5)


@numba.njit(parallel=True, cache=True)
def gather_kinematics(x, v, m, rho, S, order, n):
    """Copy position, velocity, mass and density into cell order (S[k, G*])."""
    for k in prange(n):
        i = order[k]
        S[k, GX] = x[0, i]
        S[k, GY] = x[1, i]
        S[k, GZ] = x[2, i]
        S[k, GVX] = v[0, i]
        S[k, GVY] = v[1, i]
        S[k, GVZ] = v[2, i]
        S[k, GM] = m[i]
        S[k, GRHO] = rho[i]


@numba.njit(parallel=True, cache=True)
def gather_stress(sig, R, rho, cs, B, S, order, n):
    """Copy sigma/rho^2, the artificial stress, the sound speed and B into cell order (S[k, G*])."""
    for k in prange(n):
        i = order[k]
        r2 = 1.0 / (rho[i] * rho[i])
        S[k, GRHO] = rho[i]
        for c in range(6):
            S[k, GP0 + c] = sig[c, i] * r2
            S[k, GR0 + c] = R[c, i]
        S[k, GCS] = cs[i]
        for c in range(9):
            S[k, GB0 + c] = B[c, i]


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def gradient_pass(S, order, n, start, ncx, ncy, ncz, x0, y0, z0, cell, h, corrected, nbr, cnt, L, B, rmin):
    """Velocity gradient L_i = (1/rho_i) sum_j m_j (v_j - v_i) (x) B_i grad_i W_ij (Gray et al. 2001
    eq. 2) with the correction B_i = M_i^-T (module docstring), the nearest-neighbour distance, and the
    neighbour list: nbr[k, :cnt[k]] the cell-order indices of particle order[k]'s neighbours (r < 2h).
    Returns the largest neighbour count; a particle with more than nbr.shape[1] neighbours has its list
    cut (the caller enlarges ``nbr`` and runs the pass again; the pass reads only S)."""
    rc2 = 4.0 * h * h
    cap = nbr.shape[1]
    nsten = 2
    worst = 0
    for k in prange(n):
        i = order[k]
        xi = S[k, GX]
        yi = S[k, GY]
        zi = S[k, GZ]
        vxi = S[k, GVX]
        vyi = S[k, GVY]
        vzi = S[k, GVZ]
        cx = min(int((xi - x0) / cell), ncx - 1)
        cy = min(int((yi - y0) / cell), ncy - 1)
        cz = min(int((zi - z0) / cell), ncz - 1)
        l00 = 0.0
        l01 = 0.0
        l02 = 0.0
        l10 = 0.0
        l11 = 0.0
        l12 = 0.0
        l20 = 0.0
        l21 = 0.0
        l22 = 0.0
        m00 = 0.0
        m01 = 0.0
        m02 = 0.0
        m10 = 0.0
        m11 = 0.0
        m12 = 0.0
        m20 = 0.0
        m21 = 0.0
        m22 = 0.0
        rmin2 = math.inf
        c = 0
        lo_x = max(cx - nsten, 0)
        hi_x = min(cx + nsten, ncx - 1)
        for nz in range(max(cz - nsten, 0), min(cz + nsten + 1, ncz)):
            for ny in range(max(cy - nsten, 0), min(cy + nsten + 1, ncy)):
                row = (nz * ncy + ny) * ncx
                for l in range(start[row + lo_x], start[row + hi_x + 1]):
                    dx = xi - S[l, GX]
                    dy = yi - S[l, GY]
                    dz = zi - S[l, GZ]
                    r2 = dx * dx + dy * dy + dz * dz
                    if r2 >= rc2 or l == k:
                        continue
                    if c < cap:
                        nbr[k, c] = l
                    c += 1
                    if r2 < rmin2:
                        rmin2 = r2
                    r = math.sqrt(r2)
                    fw = gradw_factor3(r, h)
                    mj = S[l, GM]
                    gx = mj * fw * dx
                    gy = mj * fw * dy
                    gz = mj * fw * dz
                    dvx = S[l, GVX] - vxi
                    dvy = S[l, GVY] - vyi
                    dvz = S[l, GVZ] - vzi
                    l00 += dvx * gx
                    l01 += dvx * gy
                    l02 += dvx * gz
                    l10 += dvy * gx
                    l11 += dvy * gy
                    l12 += dvy * gz
                    l20 += dvz * gx
                    l21 += dvz * gy
                    l22 += dvz * gz
                    m00 -= dx * gx
                    m01 -= dx * gy
                    m02 -= dx * gz
                    m10 -= dy * gx
                    m11 -= dy * gy
                    m12 -= dy * gz
                    m20 -= dz * gx
                    m21 -= dz * gy
                    m22 -= dz * gz
        cnt[k] = c
        worst = max(worst, c)
        ir = 1.0 / S[k, GRHO]
        b00 = 1.0
        b01 = 0.0
        b02 = 0.0
        b10 = 0.0
        b11 = 1.0
        b12 = 0.0
        b20 = 0.0
        b21 = 0.0
        b22 = 1.0
        if corrected:
            m00 *= ir
            m01 *= ir
            m02 *= ir
            m10 *= ir
            m11 *= ir
            m12 *= ir
            m20 *= ir
            m21 *= ir
            m22 *= ir
            # cofactors of M: M^-T = cof(M) / det M
            k00 = m11 * m22 - m12 * m21
            k01 = m12 * m20 - m10 * m22
            k02 = m10 * m21 - m11 * m20
            k10 = m02 * m21 - m01 * m22
            k11 = m00 * m22 - m02 * m20
            k12 = m01 * m20 - m00 * m21
            k20 = m01 * m12 - m02 * m11
            k21 = m02 * m10 - m00 * m12
            k22 = m00 * m11 - m01 * m10
            det = m00 * k00 + m01 * k01 + m02 * k02
            if det > 0.0:
                # smallest singular value of M: the smallest eigenvalue of M^T M
                g00 = m00 * m00 + m10 * m10 + m20 * m20
                g11 = m01 * m01 + m11 * m11 + m21 * m21
                g22 = m02 * m02 + m12 * m12 + m22 * m22
                g01 = m00 * m01 + m10 * m11 + m20 * m21
                g12 = m01 * m02 + m11 * m12 + m21 * m22
                g02 = m00 * m02 + m10 * m12 + m20 * m22
                _, _, smin2 = sym_eig3(g00, g11, g22, g01, g12, g02)
                if smin2 > SMIN_CORR * SMIN_CORR:
                    idet = 1.0 / det
                    b00 = k00 * idet
                    b01 = k01 * idet
                    b02 = k02 * idet
                    b10 = k10 * idet
                    b11 = k11 * idet
                    b12 = k12 * idet
                    b20 = k20 * idet
                    b21 = k21 * idet
                    b22 = k22 * idet
        # L = raw . B^T  (L_ac = raw_ab B_cb)
        L[0, i] = ir * (l00 * b00 + l01 * b01 + l02 * b02)
        L[1, i] = ir * (l00 * b10 + l01 * b11 + l02 * b12)
        L[2, i] = ir * (l00 * b20 + l01 * b21 + l02 * b22)
        L[3, i] = ir * (l10 * b00 + l11 * b01 + l12 * b02)
        L[4, i] = ir * (l10 * b10 + l11 * b11 + l12 * b12)
        L[5, i] = ir * (l10 * b20 + l11 * b21 + l12 * b22)
        L[6, i] = ir * (l20 * b00 + l21 * b01 + l22 * b02)
        L[7, i] = ir * (l20 * b10 + l21 * b11 + l22 * b12)
        L[8, i] = ir * (l20 * b20 + l21 * b21 + l22 * b22)
        B[0, i] = b00
        B[1, i] = b01
        B[2, i] = b02
        B[3, i] = b10
        B[4, i] = b11
        B[5, i] = b12
        B[6, i] = b20
        B[7, i] = b21
        B[8, i] = b22
        rmin[i] = math.sqrt(rmin2)
    return worst


@numba.njit(parallel=True, cache=True)
def update_state(L, rho, sig, R, cs, est, m, mat, mats, eps_as, dt):
    """Advance density and stress by dt from L (continuity, Jaumann rate: module docstring), then the
    artificial stress R (Gray et al. 2001 eqs. 27-30), the sound speed and the stress work."""
    for i in prange(rho.shape[0]):
        mt_ = mat[i]
        rho_old = rho[i]
        l00 = L[0, i]
        l01 = L[1, i]
        l02 = L[2, i]
        l10 = L[3, i]
        l11 = L[4, i]
        l12 = L[5, i]
        l20 = L[6, i]
        l21 = L[7, i]
        l22 = L[8, i]
        tr = l00 + l11 + l22
        rn = rho_old * math.exp(-tr * dt)
        rho[i] = rn
        fac = 1.0 - mats[mt_, M_D0]
        lam = fac * mats[mt_, M_C12]
        g2 = 2.0 * fac * mats[mt_, M_C66]
        e0 = l00
        e1 = l11
        e2 = l22
        e3 = 0.5 * (l01 + l10)
        e4 = 0.5 * (l12 + l21)
        e5 = 0.5 * (l20 + l02)
        w01 = 0.5 * (l01 - l10)
        w12 = 0.5 * (l12 - l21)
        w02 = 0.5 * (l02 - l20)
        s0 = sig[0, i]
        s1 = sig[1, i]
        s2 = sig[2, i]
        s3 = sig[3, i]
        s4 = sig[4, i]
        s5 = sig[5, i]
        # P = Omega sigma (Omega = [[0, w01, w02], [-w01, 0, w12], [-w02, -w12, 0]]); the Jaumann
        # spin term Omega sigma - sigma Omega = P + P^T
        p00 = w01 * s3 + w02 * s5
        p01 = w01 * s1 + w02 * s4
        p02 = w01 * s4 + w02 * s2
        p10 = -w01 * s0 + w12 * s5
        p11 = -w01 * s3 + w12 * s4
        p12 = -w01 * s5 + w12 * s2
        p20 = -w02 * s0 - w12 * s3
        p21 = -w02 * s3 - w12 * s1
        p22 = -w02 * s5 - w12 * s4
        le = lam * tr
        n0 = s0 + dt * (le + g2 * e0 + 2.0 * p00)
        n1 = s1 + dt * (le + g2 * e1 + 2.0 * p11)
        n2 = s2 + dt * (le + g2 * e2 + 2.0 * p22)
        n3 = s3 + dt * (g2 * e3 + p01 + p10)
        n4 = s4 + dt * (g2 * e4 + p12 + p21)
        n5 = s5 + dt * (g2 * e5 + p20 + p02)
        vol = m[i] / (0.5 * (rn + rho_old))
        est[i] += dt * vol * 0.5 * ((s0 + n0) * e0 + (s1 + n1) * e1 + (s2 + n2) * e2
                                    + 2.0 * ((s3 + n3) * e3 + (s4 + n4) * e4 + (s5 + n5) * e5))
        sig[0, i] = n0
        sig[1, i] = n1
        sig[2, i] = n2
        sig[3, i] = n3
        sig[4, i] = n4
        sig[5, i] = n5
        r0 = 0.0
        r1 = 0.0
        r2 = 0.0
        r3 = 0.0
        r4 = 0.0
        r5 = 0.0
        if eps_as > 0.0:
            # Gershgorin: no row can hold a positive eigenvalue -> no tension, R = 0 without the eigenvalues
            a3 = abs(n3)
            a4 = abs(n4)
            a5 = abs(n5)
            if n0 + a3 + a5 > 0.0 or n1 + a3 + a4 > 0.0 or n2 + a4 + a5 > 0.0:
                q1, q2, q3 = sym_eig3(n0, n1, n2, n3, n4, n5)
                if q1 > 0.0:
                    ir2 = eps_as / (rn * rn)
                    t1 = -q1 * ir2
                    t2 = -q2 * ir2 if q2 > 0.0 else 0.0
                    t3 = -q3 * ir2 if q3 > 0.0 else 0.0
                    r0, r1, r2, r3, r4, r5 = spectral_map3(n0, n1, n2, n3, n4, n5, q1, q2, q3, t1, t2, t3)
        R[0, i] = r0
        R[1, i] = r1
        R[2, i] = r2
        R[3, i] = r3
        R[4, i] = r4
        R[5, i] = r5
        cs[i] = math.sqrt(mats[mt_, M_CMAX] * fac / rn)


@numba.njit(cache=True)
def artificial_stress_reach2(h, iwdp, nexp):
    """Squared distance beyond which f^n = (W(r) / W(dp))^n < 1e-6 (bisection; as 2D)."""
    lo = 0.0
    hi = 2.0 * h
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if (w_cubic3(mid, h) * iwdp) ** nexp > 1e-6:
            lo = mid
        else:
            hi = mid
    return hi * hi


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def momentum_pass(S, order, n, nbr, cnt, h, alpha, beta, eps_as, nexp, wdp, a, av, ar, x, walls):
    """Acceleration dv_i/dt = sum_j m_j (sigma_i/rho_i^2 B_i + sigma_j/rho_j^2 B_j + f^n (R_i + R_j)
    - Pi_ij I) . grad_i W_ij + the walls' (Gray et al. 2001 eqs. 1, 26; Monaghan 2005 eqs. 3.13, 4.9),
    over the neighbour list of :func:`gradient_pass`; writes a, and its viscous (av) and
    artificial-stress (ar) parts."""
    eta2 = 0.01 * h * h
    use_as = eps_as > 0.0
    iwdp = 1.0 / wdp
    ras2 = artificial_stress_reach2(h, iwdp, nexp) if use_as else 4.0 * h * h
    for k in prange(n):
        i = order[k]
        xi = S[k, GX]
        yi = S[k, GY]
        zi = S[k, GZ]
        vxi = S[k, GVX]
        vyi = S[k, GVY]
        vzi = S[k, GVZ]
        ci = S[k, GCS]
        rhoi = S[k, GRHO]
        p0 = S[k, GP0]
        p1 = S[k, GP1]
        p2 = S[k, GP2]
        p3 = S[k, GP3]
        p4 = S[k, GP4]
        p5 = S[k, GP5]
        q0 = S[k, GR0]
        q1 = S[k, GR1]
        q2 = S[k, GR2]
        q3 = S[k, GR3]
        q4 = S[k, GR4]
        q5 = S[k, GR5]
        b00 = S[k, GB0]
        b01 = S[k, GB1]
        b02 = S[k, GB2]
        b10 = S[k, GB3]
        b11 = S[k, GB4]
        b12 = S[k, GB5]
        b20 = S[k, GB6]
        b21 = S[k, GB7]
        b22 = S[k, GB8]
        ax = 0.0
        ay = 0.0
        az = 0.0
        vx_ = 0.0
        vy_ = 0.0
        vz_ = 0.0
        sx_ = 0.0
        sy_ = 0.0
        sz_ = 0.0
        for c in range(cnt[k]):
            l = nbr[k, c]
            dx = xi - S[l, GX]
            dy = yi - S[l, GY]
            dz = zi - S[l, GZ]
            r2 = dx * dx + dy * dy + dz * dz
            r = math.sqrt(r2)
            fw = gradw_factor3(r, h)
            gx = fw * dx
            gy = fw * dy
            gz = fw * dz
            mj = S[l, GM]
            # B_i g and B_j g
            ux = b00 * gx + b01 * gy + b02 * gz
            uy = b10 * gx + b11 * gy + b12 * gz
            uz = b20 * gx + b21 * gy + b22 * gz
            wx = S[l, GB0] * gx + S[l, GB1] * gy + S[l, GB2] * gz
            wy = S[l, GB3] * gx + S[l, GB4] * gy + S[l, GB5] * gz
            wz = S[l, GB6] * gx + S[l, GB7] * gy + S[l, GB8] * gz
            j0 = S[l, GP0]
            j1 = S[l, GP1]
            j2 = S[l, GP2]
            j3 = S[l, GP3]
            j4 = S[l, GP4]
            j5 = S[l, GP5]
            fx = p0 * ux + p3 * uy + p5 * uz + j0 * wx + j3 * wy + j5 * wz
            fy = p3 * ux + p1 * uy + p4 * uz + j3 * wx + j1 * wy + j4 * wz
            fz = p5 * ux + p4 * uy + p2 * uz + j5 * wx + j4 * wy + j2 * wz
            # Monaghan viscosity
            vdr = (vxi - S[l, GVX]) * dx + (vyi - S[l, GVY]) * dy + (vzi - S[l, GVZ]) * dz
            if vdr < 0.0:
                mu = h * vdr / (r2 + eta2)
                pij = (-alpha * 0.5 * (ci + S[l, GCS]) * mu + beta * mu * mu) / (0.5 * (rhoi + S[l, GRHO]))
                vx_ -= mj * pij * gx
                vy_ -= mj * pij * gy
                vz_ -= mj * pij * gz
                fx -= pij * gx
                fy -= pij * gy
                fz -= pij * gz
            # Gray-Monaghan-Swift artificial stress
            if use_as and r2 < ras2:
                t0 = q0 + S[l, GR0]
                t1 = q1 + S[l, GR1]
                t2 = q2 + S[l, GR2]
                t3 = q3 + S[l, GR3]
                t4 = q4 + S[l, GR4]
                t5 = q5 + S[l, GR5]
                if t0 != 0.0 or t1 != 0.0 or t2 != 0.0 or t3 != 0.0 or t4 != 0.0 or t5 != 0.0:
                    f = w_cubic3(r, h) * iwdp
                    fn = f
                    for _ in range(nexp - 1):
                        fn *= f
                    rx = fn * (t0 * gx + t3 * gy + t5 * gz)
                    ry = fn * (t3 * gx + t1 * gy + t4 * gz)
                    rz = fn * (t5 * gx + t4 * gy + t2 * gz)
                    sx_ += mj * rx
                    sy_ += mj * ry
                    sz_ += mj * rz
                    fx += rx
                    fy += ry
                    fz += rz
            ax += mj * fx
            ay += mj * fy
            az += mj * fz
        wxa, wya, wza = wall_accel(x[0, i], x[1, i], x[2, i], walls)
        a[0, i] = ax + wxa
        a[1, i] = ay + wya
        a[2, i] = az + wza
        av[0, i] = vx_
        av[1, i] = vy_
        av[2, i] = vz_
        ar[0, i] = sx_
        ar[1, i] = sy_
        ar[2, i] = sz_


@numba.njit(cache=True)
def signal_dt(v, cs, h):
    """Signal-speed time step min_i h / (c_i + |v_i|) (Monaghan 2005 sec. 6)."""
    dt = math.inf
    for i in range(cs.shape[0]):
        s = math.sqrt(v[0, i] * v[0, i] + v[1, i] * v[1, i] + v[2, i] * v[2, i])
        d = h / (cs[i] + s)
        if d < dt:
            dt = d
    return dt
