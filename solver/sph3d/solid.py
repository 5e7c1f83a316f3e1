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
  isotropic (lambda = C12, G = C66 of the 2D material row, :mod:`solver.sph3d.particles`), the
  stiffness reduced by the damage D0 a converted particle starts with;
* tensile damage after conversion (the 2D law of :mod:`solver.sph.solid` in three dimensions: our
  law, a tension-only damage as in LAMMPS SMD's Grady-Kipp-type models): while the largest principal
  stress of the state is tensile, the largest principal strain rate accumulates
  kappa += max(eps_dot_1, 0) dt and d = min(1, kappa / kappa_f); the acting stress keeps the
  compressive principal parts and scales the tensile ones by (1 - d). At d = 1 the particle is a
  powder grain: no tension (the state is clipped to its compressive part) and its density floored at
  the solid's rho0 (grains moving apart open gaps, they do not dilate); without it a particle pulled
  apart keeps its tension while its density falls and its sound speed sqrt(C / rho) grows without
  bound (the tensile instability runs away);
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
* stress work: (m_i / rho_i) sigma_i : eps_dot_i dt, trapezoidal in the acting sigma (as 2D).

Both pair loops visit each pair once (the half stencil; the 2D momentum pass's scheme, here also
for the velocity gradient): chunks of the cell order add the partner's share into their own
accumulator, a second pass sums the chunks in a fixed order (results independent of the thread
count). The velocity-gradient pass also writes the half neighbour list (partner, kernel factor,
artificial-stress weight) that the momentum pass runs over, so the cell stencil is searched and
the kernel evaluated once per pair and step (the chunk driver enlarges the list when a row is full).
Each law's pair term is its own inline function (:func:`velocity_gradient_terms`,
:func:`correction_terms`, :func:`stress_term`, :func:`monaghan_pi`, :func:`artificial_stress_term`);
the pair loops hand each term to both particles of the pair (:func:`share_pair`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from ..sph.materials import M_C12, M_C66, M_CMAX, M_D0, M_KAPPA_F, M_RHO0
from ..tensor3 import sym_eig3
from ..sph.chunks import chunk_rows, clear_rows, close_row, share_pair, sum_chunks
from .cells import HALF_ROWS, cell_coords3, half_stencil
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


@numba.njit(cache=True, inline="always")
def kinematics(S, k):
    """Position, velocity and mass of particle k (cell order)."""
    return S[k, GX], S[k, GY], S[k, GZ], S[k, GVX], S[k, GVY], S[k, GVZ], S[k, GM]


@numba.njit(cache=True, inline="always")
def difference(ax, ay, az, S, l, col):
    """a_i - a_l of the vector held in columns col .. col + 2 of S: x_ij from GX, v_ij from GVX."""
    return ax - S[l, col], ay - S[l, col + 1], az - S[l, col + 2]


@numba.njit(cache=True, inline="always")
def kernel_gradient(fw, dx, dy, dz):
    """grad_i W_ij = F(r_ij) x_ij, F the kernel factor (dW/dr) / r (:mod:`solver.sph3d.kernel`)."""
    return fw * dx, fw * dy, fw * dz


@numba.njit(cache=True, inline="always")
def stress_weight(w, iwdp, nexp):
    """The artificial stress's pair weight f_ij^n, f_ij = W(r_ij) / W(dp) (Gray et al. 2001 eq. 26), n an
    integer, by repeated multiplication."""
    f = w * iwdp
    fn = f
    for _ in range(nexp - 1):
        fn *= f
    return fn


@numba.njit(cache=True, inline="always")
def list_partner(nbr, nfw, nfn, k, c, l, fw, fn):
    """Entry c of row k of the half neighbour list: partner l, kernel factor F(r), artificial-stress weight
    f^n; not kept when the row is full (the caller enlarges the list). Returns c + 1."""
    if c < nbr.shape[1]:
        nbr[k, c] = l
        nfw[k, c] = fw
        nfn[k, c] = fn
    return c + 1


@numba.njit(cache=True, inline="always")
def velocity_gradient_terms(vx, vy, vz, gx, gy, gz):
    """The pair term of the velocity gradient (Gray et al. 2001 eq. 2; Libersky & Petschek 1991),
        rho_i (dv^a/dx^b)_i = sum_j m_j v_ji^a g^b    (before the correction B_i),
    g = grad_i W_ij, from v_ij = v_i - v_j: v_ji (x) g, row-major. Even in (i, j) (v_ji (x) g_ji =
    v_ij (x) g), so j's sum gains m_i times the same term."""
    ux = -vx
    uy = -vy
    uz = -vz
    return ux * gx, ux * gy, ux * gz, uy * gx, uy * gy, uy * gz, uz * gx, uz * gy, uz * gz


@numba.njit(cache=True, inline="always")
def correction_terms(dx, dy, dz, gx, gy, gz):
    """The pair term of the correction matrix (Randles & Libersky 1996; Bonet & Lok 1999),
        rho_i M_i = sum_j m_j x_ji (x) g,
    g = grad_i W_ij, from x_ij = x_i - x_j: x_ji (x) g in the order xx, yy, zz, xy, yz, zx (symmetric: g is
    parallel to x_ij). Even in (i, j), as :func:`velocity_gradient_terms`."""
    ux = -dx
    uy = -dy
    uz = -dz
    return ux * gx, uy * gy, uz * gz, ux * gy, uy * gz, ux * gz


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def gradient_pass(S, n, start, ncx, ncy, ncz, x0, y0, z0, cell, h, wdp, nexp, nbr, nfw, nfn, cnt, A):
    """The pair sums of the velocity gradient and of the correction matrix (:func:`velocity_gradient_terms`,
    :func:`correction_terms`), each pair visited once, and the half neighbour list.

    Particle k (cell order) visits the later particles l of its half stencil
    (:func:`solver.sph3d.cells.half_stencil`) within the support 2h: k gains m_l times the pair's terms,
    l gains m_k times them (:func:`share_pair`). Chunks of the cell order add into their own accumulator
    A[t] (as 2D's momentum pass), :func:`finish_gradient` sums them in a fixed order, so the result does
    not depend on the thread count; the last column holds the smallest squared pair distance. The list
    row k holds the partners l, the kernel factor F(r) and the artificial-stress weight f^n
    (:func:`stress_weight`) of each, for :func:`momentum_pass` (positions do not move between the two
    passes). Returns the longest row; a row longer than nbr.shape[1] is cut (the caller enlarges the list
    and runs the pass again: it reads only S)."""
    rc2 = 4.0 * h * h
    iwdp = 1.0 / wdp
    n_chunks = A.shape[0]
    wmax = np.zeros(n_chunks, np.int64)
    for t in prange(n_chunks):
        k0, k1 = chunk_rows(t, n, n_chunks)
        clear_rows(A, t, k0, n, NACC)
        A[t, k0:, NACC] = math.inf
        own = np.zeros(NACC)
        lo = np.empty(HALF_ROWS, np.int64)
        hi = np.empty(HALF_ROWS, np.int64)
        wt = 0
        for k in range(k0, k1):
            xi, yi, zi, vxi, vyi, vzi, mi = kinematics(S, k)
            cx, cy, cz = cell_coords3(xi, yi, zi, x0, y0, z0, cell, ncx, ncy, ncz)
            rmin2 = A[t, k, NACC]
            c = 0
            for r in range(half_stencil(k, cx, cy, cz, start, ncx, ncy, ncz, lo, hi)):
                for l in range(lo[r], hi[r]):
                    dx, dy, dz = difference(xi, yi, zi, S, l, GX)
                    r2 = dx * dx + dy * dy + dz * dz
                    if r2 >= rc2:
                        continue
                    w, fw = w_and_factor3(math.sqrt(r2), h)
                    c = list_partner(nbr, nfw, nfn, k, c, l, fw, stress_weight(w, iwdp, nexp))
                    if r2 < rmin2:
                        rmin2 = r2
                    if r2 < A[t, l, NACC]:
                        A[t, l, NACC] = r2
                    gx, gy, gz = kernel_gradient(fw, dx, dy, dz)
                    vx, vy, vz = difference(vxi, vyi, vzi, S, l, GVX)
                    mj = S[l, GM]
                    share_pair(own, A, t, l, 0, velocity_gradient_terms(vx, vy, vz, gx, gy, gz), mj, mi)
                    share_pair(own, A, t, l, 9, correction_terms(dx, dy, dz, gx, gy, gz), mj, mi)
            cnt[k] = c
            if c > wt:
                wt = c
            close_row(A, t, k, own)
            A[t, k, NACC] = rmin2
        wmax[t] = wt
    return wmax.max()


@numba.njit(cache=True, inline="always")
def correction(m00, m11, m22, m01, m12, m02):
    """The kernel-gradient correction B = M^-T = M^-1 of the symmetric M (Randles & Libersky 1996; Bonet
    & Lok 1999) where det M > 0 and its smallest singular value is above SMIN_CORR, else I; row-major.
    The smallest singular value of the symmetric M is its smallest |eigenvalue|; Gershgorin's lower bound
    min_a (M_aa - sum_b |M_ab|) settles it without the eigenvalues in a full neighbourhood (M close
    to I)."""
    k00 = m11 * m22 - m12 * m12
    k01 = m12 * m02 - m01 * m22
    k02 = m01 * m12 - m11 * m02
    k11 = m00 * m22 - m02 * m02
    k12 = m01 * m02 - m00 * m12
    k22 = m00 * m11 - m01 * m01
    det = m00 * k00 + m01 * k01 + m02 * k02
    if det > 0.0:
        a01 = abs(m01)
        a12 = abs(m12)
        a02 = abs(m02)
        smin = min(m00 - a01 - a02, m11 - a01 - a12, m22 - a02 - a12)
        if smin <= SMIN_CORR:
            e1, e2, e3 = sym_eig3(m00, m11, m22, m01, m12, m02)
            smin = min(abs(e1), abs(e2), abs(e3))
        if smin > SMIN_CORR:
            idet = 1.0 / det
            b01 = k01 * idet
            b02 = k02 * idet
            b12 = k12 * idet
            return k00 * idet, b01, b02, b01, k11 * idet, b12, b02, b12, k22 * idet
    return 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0


@numba.njit(parallel=True, cache=True)
def finish_gradient(S, order, n, A, corrected, L, B, rmin):
    """Sum the chunk accumulators of :func:`gradient_pass` (:func:`sum_chunks`), then the correction
    B_i (:func:`correction`; B_i = I without ``corrected``), L_i = raw_i B_i^T with
    raw_i = (1/rho_i) sum_j m_j v_ji (x) grad_i W_ij, and the nearest-neighbour distance."""
    for k in prange(n):
        nt = sum_chunks(A, k, n, NACC)
        rmin2 = A[0, k, NACC]
        for t in range(1, nt):
            if A[t, k, NACC] < rmin2:
                rmin2 = A[t, k, NACC]
        raw = A[0, k]
        i = order[k]
        ir = 1.0 / S[k, GRHO]
        b = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        if corrected:
            b = correction(raw[9] * ir, raw[10] * ir, raw[11] * ir, raw[12] * ir, raw[13] * ir, raw[14] * ir)
        for r in range(3):
            l0 = raw[3 * r] * ir
            l1 = raw[3 * r + 1] * ir
            l2 = raw[3 * r + 2] * ir
            for c in range(3):
                L[3 * r + c, i] = l0 * b[3 * c] + l1 * b[3 * c + 1] + l2 * b[3 * c + 2]
                B[3 * r + c, i] = b[3 * r + c]
        rmin[i] = math.sqrt(rmin2)


@numba.njit(cache=True, inline="always")
def tensor_at(a, i):
    """The row-major 3x3 tensor a[0:9, i] as nine scalars."""
    return a[0, i], a[1, i], a[2, i], a[3, i], a[4, i], a[5, i], a[6, i], a[7, i], a[8, i]


@numba.njit(cache=True, inline="always")
def voigt_at(a, i):
    """The symmetric tensor a[0:6, i] (Voigt order xx, yy, zz, xy, yz, zx) as six scalars."""
    return a[0, i], a[1, i], a[2, i], a[3, i], a[4, i], a[5, i]


@numba.njit(cache=True, inline="always")
def set_voigt(a, i, s):
    """a[0:6, i] = the six Voigt components s."""
    for c in range(6):
        a[c, i] = s[c]


@numba.njit(cache=True, inline="always")
def may_be_tensile(s0, s1, s2, s3, s4, s5):
    """False when no principal value of s can be positive (Gershgorin: every row's diagonal plus its
    off-diagonal magnitudes <= 0), so the eigenvalues are not needed."""
    a3 = abs(s3)
    a4 = abs(s4)
    a5 = abs(s5)
    return s0 + a3 + a5 > 0.0 or s1 + a3 + a4 > 0.0 or s2 + a4 + a5 > 0.0


@numba.njit(parallel=True, cache=True)
def update_state(L, rho, sig, sst, dmg, R, cs, est, m, mat, mats, eps_as, dt):
    """Advance density, stress and tensile damage by dt from L (continuity, Jaumann rate, damage:
    module docstring), then the acting stress ``sig``, the artificial stress R (Gray et al. 2001
    eqs. 27-30), the sound speed and the stress work. ``dmg`` rows: kappa, d; ``sst`` holds the state
    stress (before the tensile damage) of a particle with d > 0; with d = 0 the state is ``sig``."""
    for i in prange(rho.shape[0]):
        mt_ = mat[i]
        rho_old = rho[i]
        l00, l01, l02, l10, l11, l12, l20, l21, l22 = tensor_at(L, i)
        tr = l00 + l11 + l22
        rn = rho_old * math.exp(-tr * dt)
        d = dmg[1, i]
        if d >= 1.0 and rn < mats[mt_, M_RHO0]:
            rn = mats[mt_, M_RHO0]  # a powder grain does not dilate
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
        if d > 0.0:
            s0, s1, s2, s3, s4, s5 = voigt_at(sst, i)
        else:
            s0, s1, s2, s3, s4, s5 = voigt_at(sig, i)
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
        a0, a1, a2, a3, a4, a5 = n0, n1, n2, n3, n4, n5  # the acting stress
        kf = mats[mt_, M_KAPPA_F]
        if (d > 0.0 or kf < 1e300) and may_be_tensile(n0, n1, n2, n3, n4, n5):
            q1, q2, q3 = sym_eig3(n0, n1, n2, n3, n4, n5)
            if q1 > 0.0:
                if d < 1.0 and kf < 1e300:
                    r1, r2_, r3 = sym_eig3(e0, e1, e2, e3, e4, e5)
                    if r1 > 0.0:
                        dmg[0, i] += dt * r1
                        d = min(1.0, dmg[0, i] / kf)
                        dmg[1, i] = d
                if d > 0.0:
                    f = 1.0 - d
                    a0, a1, a2, a3, a4, a5 = spectral_map3(n0, n1, n2, n3, n4, n5, q1, q2, q3, q1 * f,
                                                          q2 * f if q2 > 0.0 else q2, q3 * f if q3 > 0.0 else q3)
                    if d >= 1.0:  # powder: the state forgets its tension
                        n0, n1, n2, n3, n4, n5 = a0, a1, a2, a3, a4, a5
        if d > 0.0:
            set_voigt(sst, i, (n0, n1, n2, n3, n4, n5))
        o0, o1, o2, o3, o4, o5 = voigt_at(sig, i)
        vol = m[i] / (0.5 * (rn + rho_old))
        est[i] += dt * vol * 0.5 * ((o0 + a0) * e0 + (o1 + a1) * e1 + (o2 + a2) * e2
                                    + 2.0 * ((o3 + a3) * e3 + (o4 + a4) * e4 + (o5 + a5) * e5))
        set_voigt(sig, i, (a0, a1, a2, a3, a4, a5))
        r = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        if eps_as > 0.0 and may_be_tensile(a0, a1, a2, a3, a4, a5):
            q1, q2, q3 = sym_eig3(a0, a1, a2, a3, a4, a5)
            if q1 > 0.0:
                ir2 = eps_as / (rn * rn)
                t1 = -q1 * ir2
                t2 = -q2 * ir2 if q2 > 0.0 else 0.0
                t3 = -q3 * ir2 if q3 > 0.0 else 0.0
                r = spectral_map3(a0, a1, a2, a3, a4, a5, q1, q2, q3, t1, t2, t3)
        set_voigt(R, i, r)
        cs[i] = math.sqrt(mats[mt_, M_CMAX] * fac / rn)


@numba.njit(cache=True, inline="always")
def stress_term(Qi, S, l, gx, gy, gz):
    """(Q_i + Q_j) . g, Q = sigma / rho^2 . B row-major (Gray et al. 2001 eq. 1 with the corrected kernel
    gradients B grad W of Bonet & Lok 1999)."""
    return ((Qi[0] + S[l, GQ0]) * gx + (Qi[1] + S[l, GQ1]) * gy + (Qi[2] + S[l, GQ2]) * gz,
            (Qi[3] + S[l, GQ3]) * gx + (Qi[4] + S[l, GQ4]) * gy + (Qi[5] + S[l, GQ5]) * gz,
            (Qi[6] + S[l, GQ6]) * gx + (Qi[7] + S[l, GQ7]) * gy + (Qi[8] + S[l, GQ8]) * gz)


@numba.njit(cache=True, inline="always")
def monaghan_pi(vdr, r2, h, eta2, alpha, beta, c_sum, rho_sum):
    """Monaghan's viscosity Pi_ij = (-alpha c_ij mu_ij + beta mu_ij^2) / rho_ij, mu_ij =
    h min(v_ij . x_ij, 0) / (r_ij^2 + eta2) (approaching pairs only: Pi = 0 when v_ij . x_ij >= 0), with
    the pair means c_ij = c_sum / 2, rho_ij = rho_sum / 2 (Monaghan 1992 ARAA 30:543; 2005 eq. 4.9)."""
    mu = h * min(vdr, 0.0) / (r2 + eta2)
    return (-alpha * c_sum * mu + 2.0 * beta * mu * mu) / rho_sum


@numba.njit(cache=True, inline="always")
def artificial_stress_term(fn, Ri, S, l, gx, gy, gz):
    """f_ij^n (R_i + R_j) . g, R the artificial stress in Voigt order xx, yy, zz, xy, yz, zx (Gray et al.
    2001 eq. 26)."""
    t0 = Ri[0] + S[l, GR0]
    t1 = Ri[1] + S[l, GR1]
    t2 = Ri[2] + S[l, GR2]
    t3 = Ri[3] + S[l, GR3]
    t4 = Ri[4] + S[l, GR4]
    t5 = Ri[5] + S[l, GR5]
    return fn * (t0 * gx + t3 * gy + t5 * gz), fn * (t3 * gx + t1 * gy + t4 * gz), fn * (t5 * gx + t4 * gy + t2 * gz)


@numba.njit(parallel=True, cache=True, fastmath=FAST)
def momentum_pass(S, n, nbr, nfw, nfn, cnt, h, alpha, beta, use_as, A):
    """The pair sums of the acceleration dv_i/dt = sum_j m_j X_ij, X_ij = (Q_i + Q_j + f^n (R_i + R_j)
    - Pi_ij I) . grad_i W_ij (Gray et al. 2001 eqs. 1, 26; Monaghan 2005 eqs. 3.13, 4.9:
    :func:`stress_term`, :func:`artificial_stress_term`, :func:`monaghan_pi`), over the half neighbour
    list of :func:`gradient_pass`: each pair once, X_ji = -X_ij, so i gains m_j X_ij and j loses
    m_i X_ij (:func:`share_pair`; momentum is conserved to round-off). Chunk t's accumulator A[t, :, 0:9]
    takes a, its viscous part and its artificial-stress part; :func:`finish_momentum` sums the chunks.
    The artificial-stress term is skipped where f^n < 1e-6 (as 2D)."""
    eta2 = 0.01 * h * h
    n_chunks = A.shape[0]
    for t in prange(n_chunks):
        k0, k1 = chunk_rows(t, n, n_chunks)
        clear_rows(A, t, k0, n, 9)
        own = np.zeros(9)
        for k in range(k0, k1):
            xi, yi, zi, vxi, vyi, vzi, mi = kinematics(S, k)
            ci = S[k, GCS]
            rhoi = S[k, GRHO]
            Qi = (S[k, GQ0], S[k, GQ1], S[k, GQ2], S[k, GQ3], S[k, GQ4], S[k, GQ5], S[k, GQ6], S[k, GQ7], S[k, GQ8])
            Ri = (S[k, GR0], S[k, GR1], S[k, GR2], S[k, GR3], S[k, GR4], S[k, GR5])
            for c in range(cnt[k]):
                l = nbr[k, c]
                dx, dy, dz = difference(xi, yi, zi, S, l, GX)
                gx, gy, gz = kernel_gradient(nfw[k, c], dx, dy, dz)
                fx, fy, fz = stress_term(Qi, S, l, gx, gy, gz)
                vx, vy, vz = difference(vxi, vyi, vzi, S, l, GVX)
                pij = monaghan_pi(vx * dx + vy * dy + vz * dz, dx * dx + dy * dy + dz * dz, h, eta2, alpha, beta,
                                  ci + S[l, GCS], rhoi + S[l, GRHO])
                pvx = -pij * gx
                pvy = -pij * gy
                pvz = -pij * gz
                psx = 0.0
                psy = 0.0
                psz = 0.0
                fn = nfn[k, c]
                if use_as and fn > 1e-6:
                    psx, psy, psz = artificial_stress_term(fn, Ri, S, l, gx, gy, gz)
                X = (fx + (pvx + psx), fy + (pvy + psy), fz + (pvz + psz), pvx, pvy, pvz, psx, psy, psz)
                share_pair(own, A, t, l, 0, X, S[l, GM], -mi)
            close_row(A, t, k, own)


@numba.njit(parallel=True, cache=True)
def finish_momentum(order, n, A, a, av, ar, x, walls):
    """Sum the chunk accumulators of :func:`momentum_pass` (:func:`sum_chunks`) and add the walls'
    acceleration (:mod:`solver.sph3d.walls`)."""
    for k in prange(n):
        sum_chunks(A, k, n, 9)
        i = order[k]
        w = wall_accel(x[0, i], x[1, i], x[2, i], walls)
        for c in range(3):
            a[c, i] = A[0, k, c] + w[c]
            av[c, i] = A[0, k, 3 + c]
            ar[c, i] = A[0, k, 6 + c]


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
