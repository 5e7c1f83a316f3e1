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

Both pair loops visit each pair once (the half stencil; the 2D momentum pass's scheme, here also
for the velocity gradient): chunks of the cell order add the partner's share into their own
accumulator, a second pass sums the chunks in a fixed order (results independent of the thread
count). The velocity-gradient pass also writes the half neighbour list (partner, kernel factor,
artificial-stress weight) that the momentum pass runs over, so the cell stencil is searched and
the kernel evaluated once per pair and step (the chunk driver enlarges the list when a row is full).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from ..sph.materials import M_C12, M_C66, M_CMAX, M_D0
from ..tensor3 import sym_eig3
from .cells import NSTEN
from .kernel import w_and_factor3
from .particles import (GCS, GM, GQ0, GQ1, GQ2, GQ3, GQ4, GQ5, GQ6, GQ7, GQ8, GR0, GR1, GR2, GR3, GR4, GR5, GRHO, GVX,
                        GVY, GVZ, GX, GY, GZ, NACC)
from .walls import wall_accel

#: fast-math flags of the pair loops (as 2D: NaN and inf keep their IEEE meaning)
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
#: smallest singular value of M_i for which the kernel gradient is corrected (as 2D)
SMIN_CORR = 0.2


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
    """Copy Q = sigma/rho^2 . B (so that sigma_i/rho_i^2 . B_i g = Q_i g), the artificial stress and the
    sound speed into cell order (S[k, G*])."""
    for k in prange(n):
        i = order[k]
        r2 = 1.0 / (rho[i] * rho[i])
        p0 = sig[0, i] * r2
        p1 = sig[1, i] * r2
        p2 = sig[2, i] * r2
        p3 = sig[3, i] * r2
        p4 = sig[4, i] * r2
        p5 = sig[5, i] * r2
        # rows of sigma/rho^2: (p0, p3, p5), (p3, p1, p4), (p5, p4, p2); Q_ab = P_ac B_cb
        for col in range(3):
            b0 = B[col, i]
            b1 = B[3 + col, i]
            b2 = B[6 + col, i]
            S[k, GQ0 + col] = p0 * b0 + p3 * b1 + p5 * b2
            S[k, GQ3 + col] = p3 * b0 + p1 * b1 + p4 * b2
            S[k, GQ6 + col] = p5 * b0 + p4 * b1 + p2 * b2
        S[k, GRHO] = rho[i]
        for c in range(6):
            S[k, GR0 + c] = R[c, i]
        S[k, GCS] = cs[i]


def pair_buffers(n: int, n_chunks: int) -> np.ndarray:
    """Per-chunk accumulators of the symmetric pair loops, shape (n_chunks, n, NACC + 1) (the last column
    the smallest squared pair distance)."""
    return np.zeros((max(1, n_chunks), n, NACC + 1))


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def gradient_pass(S, n, start, ncx, ncy, ncz, x0, y0, z0, cell, h, wdp, nexp, nbr, nfw, nfn, cnt, A):
    """The pair sums of the velocity gradient and of the correction matrix (Gray et al. 2001 eq. 2;
    Randles & Libersky 1996), each pair visited once, and the half neighbour list.

    For a pair (i, j), d = x_i - x_j, g = grad_i W_ij = F(r) d: i gains m_j (v_j - v_i) (x) g and
    -m_j d (x) g, j gains m_i times the same two products (grad_j W_ji = -g and d_ji = -d). The half
    stencil of particle k (cell order): the rest of its own row from k + 1 on and the rows after it
    (cell id order); chunks of the cell order add into their own accumulator A[t] (as 2D's
    momentum pass), :func:`finish_gradient` sums them in a fixed order, so the result does not depend
    on the thread count. The list row k holds the later partners l (cell order), the kernel factor
    F(r) and the artificial-stress weight f^n = (W(r)/W(dp))^n of each, for :func:`momentum_pass`
    (positions do not move between the two passes). Returns the longest row; a row longer than
    nbr.shape[1] is cut (the caller enlarges the list and runs the pass again: it reads only S)."""
    rc2 = 4.0 * h * h
    cap = nbr.shape[1]
    iwdp = 1.0 / wdp
    nsten = NSTEN
    n_chunks = A.shape[0]
    wmax = np.zeros(n_chunks, np.int64)
    for t in prange(n_chunks):
        k0 = t * n // n_chunks
        k1 = (t + 1) * n // n_chunks
        for k in range(k0, n):
            for q in range(NACC):
                A[t, k, q] = 0.0
            A[t, k, NACC] = math.inf
        wt = 0
        for k in range(k0, k1):
            xi = S[k, GX]
            yi = S[k, GY]
            zi = S[k, GZ]
            vxi = S[k, GVX]
            vyi = S[k, GVY]
            vzi = S[k, GVZ]
            mi = S[k, GM]
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
            m11 = 0.0
            m22 = 0.0
            m01 = 0.0
            m12 = 0.0
            m02 = 0.0
            rmin2 = A[t, k, NACC]
            c = 0
            lo_x = max(cx - nsten, 0)
            hi_x = min(cx + nsten, ncx - 1)
            for nz in range(cz, min(cz + nsten + 1, ncz)):
                ny0 = cy if nz == cz else max(cy - nsten, 0)
                for ny in range(ny0, min(cy + nsten + 1, ncy)):
                    row = (nz * ncy + ny) * ncx
                    l_lo = k + 1 if (nz == cz and ny == cy) else start[row + lo_x]
                    for l in range(l_lo, start[row + hi_x + 1]):
                        dx = xi - S[l, GX]
                        dy = yi - S[l, GY]
                        dz = zi - S[l, GZ]
                        r2 = dx * dx + dy * dy + dz * dz
                        if r2 >= rc2:
                            continue
                        r = math.sqrt(r2)
                        w, fw = w_and_factor3(r, h)
                        f = w * iwdp
                        fn = f
                        for _ in range(nexp - 1):
                            fn *= f
                        if c < cap:
                            nbr[k, c] = l
                            nfw[k, c] = fw
                            nfn[k, c] = fn
                        c += 1
                        if r2 < rmin2:
                            rmin2 = r2
                        if r2 < A[t, l, NACC]:
                            A[t, l, NACC] = r2
                        mj = S[l, GM]
                        gx = fw * dx
                        gy = fw * dy
                        gz = fw * dz
                        dvx = S[l, GVX] - vxi
                        dvy = S[l, GVY] - vyi
                        dvz = S[l, GVZ] - vzi
                        u00 = dvx * gx
                        u01 = dvx * gy
                        u02 = dvx * gz
                        u10 = dvy * gx
                        u11 = dvy * gy
                        u12 = dvy * gz
                        u20 = dvz * gx
                        u21 = dvz * gy
                        u22 = dvz * gz
                        w00 = dx * gx
                        w11 = dy * gy
                        w22 = dz * gz
                        w01 = dx * gy
                        w12 = dy * gz
                        w02 = dx * gz
                        l00 += mj * u00
                        l01 += mj * u01
                        l02 += mj * u02
                        l10 += mj * u10
                        l11 += mj * u11
                        l12 += mj * u12
                        l20 += mj * u20
                        l21 += mj * u21
                        l22 += mj * u22
                        m00 -= mj * w00
                        m11 -= mj * w11
                        m22 -= mj * w22
                        m01 -= mj * w01
                        m12 -= mj * w12
                        m02 -= mj * w02
                        A[t, l, 0] += mi * u00
                        A[t, l, 1] += mi * u01
                        A[t, l, 2] += mi * u02
                        A[t, l, 3] += mi * u10
                        A[t, l, 4] += mi * u11
                        A[t, l, 5] += mi * u12
                        A[t, l, 6] += mi * u20
                        A[t, l, 7] += mi * u21
                        A[t, l, 8] += mi * u22
                        A[t, l, 9] -= mi * w00
                        A[t, l, 10] -= mi * w11
                        A[t, l, 11] -= mi * w22
                        A[t, l, 12] -= mi * w01
                        A[t, l, 13] -= mi * w12
                        A[t, l, 14] -= mi * w02
            cnt[k] = c
            if c > wt:
                wt = c
            A[t, k, 0] += l00
            A[t, k, 1] += l01
            A[t, k, 2] += l02
            A[t, k, 3] += l10
            A[t, k, 4] += l11
            A[t, k, 5] += l12
            A[t, k, 6] += l20
            A[t, k, 7] += l21
            A[t, k, 8] += l22
            A[t, k, 9] += m00
            A[t, k, 10] += m11
            A[t, k, 11] += m22
            A[t, k, 12] += m01
            A[t, k, 13] += m12
            A[t, k, 14] += m02
            A[t, k, NACC] = rmin2
        wmax[t] = wt
    return wmax.max()


@numba.njit(parallel=True, cache=True)
def finish_gradient(S, order, n, A, corrected, L, B, rmin):
    """Sum the chunk accumulators of :func:`gradient_pass` (fixed order), then the correction
    B_i = M_i^-T where det M_i > 0 and its smallest singular value is at least SMIN_CORR (B_i = I
    elsewhere or without ``corrected``), L_i = raw_i B_i^T, and the nearest-neighbour distance."""
    n_chunks = A.shape[0]
    for k in prange(n):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        a4 = 0.0
        a5 = 0.0
        a6 = 0.0
        a7 = 0.0
        a8 = 0.0
        a9 = 0.0
        a10 = 0.0
        a11 = 0.0
        a12 = 0.0
        a13 = 0.0
        a14 = 0.0
        rmin2 = math.inf
        for t in range(n_chunks):
            if k < t * n // n_chunks:  # chunk t only touches particles from its first one on
                break
            a0 += A[t, k, 0]
            a1 += A[t, k, 1]
            a2 += A[t, k, 2]
            a3 += A[t, k, 3]
            a4 += A[t, k, 4]
            a5 += A[t, k, 5]
            a6 += A[t, k, 6]
            a7 += A[t, k, 7]
            a8 += A[t, k, 8]
            a9 += A[t, k, 9]
            a10 += A[t, k, 10]
            a11 += A[t, k, 11]
            a12 += A[t, k, 12]
            a13 += A[t, k, 13]
            a14 += A[t, k, 14]
            if A[t, k, NACC] < rmin2:
                rmin2 = A[t, k, NACC]
        i = order[k]
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
            # M = -(1/rho_i) sum_j m_j d (x) g is symmetric (g is parallel to d)
            m00 = a9 * ir
            m11 = a10 * ir
            m22 = a11 * ir
            m01 = a12 * ir
            m12 = a13 * ir
            m02 = a14 * ir
            k00 = m11 * m22 - m12 * m12
            k01 = m12 * m02 - m01 * m22
            k02 = m01 * m12 - m11 * m02
            k11 = m00 * m22 - m02 * m02
            k12 = m01 * m02 - m00 * m12
            k22 = m00 * m11 - m01 * m01
            det = m00 * k00 + m01 * k01 + m02 * k02
            if det > 0.0:
                # smallest singular value of the symmetric M: its smallest |eigenvalue|; Gershgorin's
                # lower bound min_a (M_aa - sum_b |M_ab|) settles it without the eigenvalues in a full
                # neighbourhood (M close to I)
                a01 = abs(m01)
                a12 = abs(m12)
                a02 = abs(m02)
                smin = min(m00 - a01 - a02, m11 - a01 - a12, m22 - a02 - a12)
                if smin <= SMIN_CORR:
                    e1, e2, e3 = sym_eig3(m00, m11, m22, m01, m12, m02)
                    smin = min(abs(e1), abs(e2), abs(e3))
                if smin > SMIN_CORR:
                    idet = 1.0 / det
                    b00 = k00 * idet
                    b01 = k01 * idet
                    b02 = k02 * idet
                    b10 = b01
                    b11 = k11 * idet
                    b12 = k12 * idet
                    b20 = b02
                    b21 = b12
                    b22 = k22 * idet
        l00 = a0 * ir
        l01 = a1 * ir
        l02 = a2 * ir
        l10 = a3 * ir
        l11 = a4 * ir
        l12 = a5 * ir
        l20 = a6 * ir
        l21 = a7 * ir
        l22 = a8 * ir
        # L = raw . B^T  (L_ac = raw_ab B_cb)
        L[0, i] = l00 * b00 + l01 * b01 + l02 * b02
        L[1, i] = l00 * b10 + l01 * b11 + l02 * b12
        L[2, i] = l00 * b20 + l01 * b21 + l02 * b22
        L[3, i] = l10 * b00 + l11 * b01 + l12 * b02
        L[4, i] = l10 * b10 + l11 * b11 + l12 * b12
        L[5, i] = l10 * b20 + l11 * b21 + l12 * b22
        L[6, i] = l20 * b00 + l21 * b01 + l22 * b02
        L[7, i] = l20 * b10 + l21 * b11 + l22 * b12
        L[8, i] = l20 * b20 + l21 * b21 + l22 * b22
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


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def momentum_pass(S, n, nbr, nfw, nfn, cnt, h, alpha, beta, use_as, A):
    """The pair sums of the acceleration dv_i/dt = sum_j m_j X_ij, X_ij = (Q_i + Q_j + f^n (R_i + R_j)
    - Pi_ij I) . grad_i W_ij, Q = sigma/rho^2 . B (Gray et al. 2001 eqs. 1, 26; Monaghan 2005 eqs. 3.13,
    4.9), over the half neighbour list of :func:`gradient_pass` (each pair once: X_ji = -X_ij, i gains
    m_j X_ij, j loses m_i X_ij, so momentum is conserved to round-off), into the chunk accumulators
    A[t, :, 0:9] (a, its viscous part, its artificial-stress part); :func:`finish_momentum` sums them.
    The artificial-stress term is skipped where f^n < 1e-6 (as 2D)."""
    eta2 = 0.01 * h * h
    n_chunks = A.shape[0]
    for t in prange(n_chunks):
        k0 = t * n // n_chunks
        k1 = (t + 1) * n // n_chunks
        for k in range(k0, n):
            for q in range(9):
                A[t, k, q] = 0.0
        for k in range(k0, k1):
            xi = S[k, GX]
            yi = S[k, GY]
            zi = S[k, GZ]
            vxi = S[k, GVX]
            vyi = S[k, GVY]
            vzi = S[k, GVZ]
            mi = S[k, GM]
            ci = S[k, GCS]
            rhoi = S[k, GRHO]
            q0 = S[k, GQ0]
            q1 = S[k, GQ1]
            q2 = S[k, GQ2]
            q3 = S[k, GQ3]
            q4 = S[k, GQ4]
            q5 = S[k, GQ5]
            q6 = S[k, GQ6]
            q7 = S[k, GQ7]
            q8 = S[k, GQ8]
            r0 = S[k, GR0]
            r1 = S[k, GR1]
            r2_ = S[k, GR2]
            r3 = S[k, GR3]
            r4 = S[k, GR4]
            r5 = S[k, GR5]
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
                fw = nfw[k, c]
                dx = xi - S[l, GX]
                dy = yi - S[l, GY]
                dz = zi - S[l, GZ]
                gx = fw * dx
                gy = fw * dy
                gz = fw * dz
                mj = S[l, GM]
                fx = (q0 + S[l, GQ0]) * gx + (q1 + S[l, GQ1]) * gy + (q2 + S[l, GQ2]) * gz
                fy = (q3 + S[l, GQ3]) * gx + (q4 + S[l, GQ4]) * gy + (q5 + S[l, GQ5]) * gz
                fz = (q6 + S[l, GQ6]) * gx + (q7 + S[l, GQ7]) * gy + (q8 + S[l, GQ8]) * gz
                # Monaghan's viscosity, approaching pairs only: mu = 0 (so Pi = 0) when v_ij . r_ij >= 0
                vdr = (vxi - S[l, GVX]) * dx + (vyi - S[l, GVY]) * dy + (vzi - S[l, GVZ]) * dz
                mu = h * min(vdr, 0.0) / (dx * dx + dy * dy + dz * dz + eta2)
                pij = (-alpha * (ci + S[l, GCS]) * mu + 2.0 * beta * mu * mu) / (rhoi + S[l, GRHO])
                pvx = -pij * gx
                pvy = -pij * gy
                pvz = -pij * gz
                psx = 0.0
                psy = 0.0
                psz = 0.0
                fn = nfn[k, c]
                if use_as and fn > 1e-6:
                    t0 = r0 + S[l, GR0]
                    t1 = r1 + S[l, GR1]
                    t2 = r2_ + S[l, GR2]
                    t3 = r3 + S[l, GR3]
                    t4 = r4 + S[l, GR4]
                    t5 = r5 + S[l, GR5]
                    psx = fn * (t0 * gx + t3 * gy + t5 * gz)
                    psy = fn * (t3 * gx + t1 * gy + t4 * gz)
                    psz = fn * (t5 * gx + t4 * gy + t2 * gz)
                fx += pvx + psx
                fy += pvy + psy
                fz += pvz + psz
                ax += mj * fx
                ay += mj * fy
                az += mj * fz
                vx_ += mj * pvx
                vy_ += mj * pvy
                vz_ += mj * pvz
                sx_ += mj * psx
                sy_ += mj * psy
                sz_ += mj * psz
                A[t, l, 0] -= mi * fx
                A[t, l, 1] -= mi * fy
                A[t, l, 2] -= mi * fz
                A[t, l, 3] -= mi * pvx
                A[t, l, 4] -= mi * pvy
                A[t, l, 5] -= mi * pvz
                A[t, l, 6] -= mi * psx
                A[t, l, 7] -= mi * psy
                A[t, l, 8] -= mi * psz
            A[t, k, 0] += ax
            A[t, k, 1] += ay
            A[t, k, 2] += az
            A[t, k, 3] += vx_
            A[t, k, 4] += vy_
            A[t, k, 5] += vz_
            A[t, k, 6] += sx_
            A[t, k, 7] += sy_
            A[t, k, 8] += sz_


@numba.njit(parallel=True, cache=True)
def finish_momentum(order, n, A, a, av, ar, x, walls):
    """Sum the chunk accumulators of :func:`momentum_pass` in the fixed order t = 0, 1, ... (independent of
    the thread count) and add the walls' acceleration (:mod:`solver.sph3d.walls`)."""
    n_chunks = A.shape[0]
    for k in prange(n):
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        s4 = 0.0
        s5 = 0.0
        s6 = 0.0
        s7 = 0.0
        s8 = 0.0
        for t in range(n_chunks):
            if k < t * n // n_chunks:
                break
            s0 += A[t, k, 0]
            s1 += A[t, k, 1]
            s2 += A[t, k, 2]
            s3 += A[t, k, 3]
            s4 += A[t, k, 4]
            s5 += A[t, k, 5]
            s6 += A[t, k, 6]
            s7 += A[t, k, 7]
            s8 += A[t, k, 8]
        i = order[k]
        wx, wy, wz = wall_accel(x[0, i], x[1, i], x[2, i], walls)
        a[0, i] = s0 + wx
        a[1, i] = s1 + wy
        a[2, i] = s2 + wz
        av[0, i] = s3
        av[1, i] = s4
        av[2, i] = s5
        ar[0, i] = s6
        ar[1, i] = s7
        ar[2, i] = s8


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
