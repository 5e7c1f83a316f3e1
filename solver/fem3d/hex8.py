"""The 8-node hexahedron: one-point (uniform-gradient) integration, total-Lagrangian, assumed-strain hourglass.

Nodes: 0-3 the face zeta = -1 counter-clockwise seen from +zeta, 4-7 above them; natural
coordinates (xi, eta, zeta)_I = (-1,-1,-1), (1,-1,-1), (1,1,-1), (-1,1,-1), (-1,-1,1), ...

Kinematics (total-Lagrangian, as the 2D quad of :mod:`solver.fem.quad`). The uniform-gradient
B-matrix of the reference element (Flanagan & Belytschko 1981, IJNME 17:679) is the
derivative of the element volume with respect to a nodal coordinate, B_iI = dV/dx_iI, in closed form

    B_x1 = (1/12) [ y2 ((z6 - z3) - (z4 - z5)) + y3 (z2 - z4) + y4 ((z3 - z8) - (z5 - z2))
                    + y5 ((z8 - z6) - (z2 - z4)) + y6 (z5 - z2) + y8 (z4 - z5) ]

(1-based nodes), the other nodes by FB's permutation of the node numbers and B_y, B_z by the
cyclic permutation x -> y -> z of the coordinates. The volume is V = sum_I B_xI x_I and the mean
gradient b_iI = B_iI / V (= (1/V) int dN_I/dx_i dV exactly, so a constant stress is in equilibrium
at every interior node of any mesh: the patch test). With b0 that of the reference element the
deformation gradient is F_ij = sum_I x_iI b0_jI, the Green-Lagrange strain E = (F^T F - I) / 2, the
2nd Piola-Kirchhoff stress S = C : E (:mod:`.material3d`; an inelastic material's S from its law,
:mod:`.laws3d`, the hourglass resistance scaled by its smallest secant ratio, :func:`hourglass_scale`),
the first Piola-Kirchhoff P = F S and the nodal internal force f_iI = V0 P_ij b0_jI. This is the Cauchy stress form f_iI = V sigma_ij b_jI
with sigma = F S F^T / J and b = F^-T b0 (:func:`cauchy_stress` reports sigma: xx, yy, zz, xy, yz,
zx). No stress rate and no rotation of the stress are needed: E and S are invariant under rigid
rotations (the 2D element's choice; a Jaumann or Hughes-Winget update of the Cauchy stress is the
updated-Lagrangian equivalent, and would also rotate a fibre's frame, which the total-Lagrangian
law does exactly). :func:`velocity_gradient` gives L = sum_I v_I (x) b_I at the current
configuration (zero symmetric part for a rigid motion).

Hourglass control: the Flanagan-Belytschko base vectors and their gamma vectors (FB 1981)

    Gamma_0 = eta zeta, Gamma_1 = xi zeta, Gamma_2 = xi eta, Gamma_3 = xi eta zeta  (at the nodes),
    gamma_aI = (Gamma_aI - (Gamma_a . X_i) b0_iI) / 8,

orthogonal to every linear field of the reference element, give the hourglass amplitudes
q_a = sum_I gamma_aI x_I (zero for every affine motion, rigid rotations included). They are
rotated back to the reference frame by the polar rotation R of F (F = R U, Newton's iteration
R <- (R + R^-T) / 2) and split along the element's axes t1 = unit(dX/dxi), t2 (dX/deta made
orthogonal to t1), t3 = t1 x t2, with half-lengths a = |dX/dxi|, b (of the orthogonalised dX/deta),
c = V0 / (8 a b): Q_ak = t_k . R^T q_a. The resistance is stiffness-type and physical, by assumed
strains (Belytschko & Bindeman 1993, CMAME 105:225, the 3D form of the 2D element's
stabilization; a mode u_k = Q Gamma_a of a box 2a x 2b x 2c carries the linear strains of the
trilinear field, the parasitic shears of the bending modes dropped):

* bending, three 2x2 blocks of normal strains linear in one natural coordinate, with the third
  normal stress free (plane stress in the block's plane):
  zeta-linear: e11 = Q(xi zeta, t1) zeta / a, e22 = Q(eta zeta, t2) zeta / b;
  eta-linear: e11 = Q(xi eta, t1) eta / a, e33 = Q(eta zeta, t3) eta / c;
  xi-linear: e22 = Q(xi eta, t2) xi / b, e33 = Q(xi zeta, t3) xi / c;
  W = (1/2)(V0/3) e^T Qps e with Qps the inverse of the block's 2x2 normal compliance in the
  element frame. A beam bends with its exact Euler-Bernoulli stiffness (the lateral strain free,
  so E, not E / (1 - nu^2)) even with one element across; a plate's anticlastic strain is free.
* twist (Q(eta zeta, t1) = q1, Q(xi zeta, t2) = q2, Q(xi eta, t3) = q3): the exact shear strains
  g12 = (q1/b + q2/a) zeta, g31 = (q1/c + q3/a) eta, g23 = (q2/c + q3/b) xi, so
  W = (V0/6) [G12 (q1/b + q2/a)^2 + G31 (q1/c + q3/a)^2 + G23 (q2/c + q3/b)^2]; the twist of a
  plate (w = k x y) is resisted by its exact in-plane shear, its transverse shears cancel.
* xi eta zeta along t_k: its normal strain only (e11 = Q eta zeta / a, bilinear), W = E_k V0 Q^2 / (18 L_k^2).

E_k, G_kl are the material's moduli along the element axes (its compliance rotated to them), so a
fibre at any orientation is handled; no tuning coefficient. An inelastic element's stiffness is scaled by the
smallest secant ratio |S| / |C : E| its centre has had (:func:`hourglass_scale`), never below
:data:`solver.fem.quad.HOURGLASS_SECANT_FLOOR` of the elastic one (as the 2D quad's): an element that flows or
softens resists bending little more than its material does, and keeps enough control for its section to stay
plane. The generalised force is
G_a = R sum_k (dW/dQ_ak) t_k and the hourglass force f_I = sum_a gamma_aI G_a; an optional viscous
part (FB 1981's viscous form, here as a fraction zeta of the critical damping of the element's
stiffest hourglass mode) adds c dQ/dt. The hourglass energy booked is the work the hourglass
forces did, trapezoidal: (G_old + G_new)/2 . (q_new - q_old) (W when elastic and unrotated).

Lumped mass: rho V0 / 8 to each node. Critical time step of an element: the one-point part's
largest frequency is bounded by omega^2 <= 8 c_max^2 b0_iI b0_iI (FB 1981's estimate; it follows
from the Christoffel bound |C^1/2 sym(u (x) b)|^2 <= rho c_max^2 |u|^2 |b|^2 whatever the
anisotropy, c_max the material's stiffest plane-wave speed), the hourglass part's by
(8 / (rho V0)) K_max max_a sum_b |gamma_a . gamma_b| (Gershgorin); dt_e = 2 / sqrt(sum of both).
For a cube of side h and nu = 0.3 it is 0.58 h / c_P (the exact one-point bound: 0.73 h / c_P).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..fem.materials import KIND
from ..fem.quad import HOURGLASS_SECANT_FLOOR
from .laws3d import ELASTIC_KIND, H3_HGD, law_stress
from .material3d import pk2_stress

#: natural coordinates of the nodes
XI = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
               [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=np.float64)
#: the four hourglass base vectors (eta zeta, xi zeta, xi eta, xi eta zeta at the nodes)
HG = np.array([XI[:, 1] * XI[:, 2], XI[:, 0] * XI[:, 2], XI[:, 0] * XI[:, 1], XI[:, 0] * XI[:, 1] * XI[:, 2]])
#: Flanagan & Belytschko's node permutation for B_x of each node (0-based)
_PERM = np.array([[2, 3, 4, 5, 6, 8], [3, 4, 1, 6, 7, 5], [4, 1, 2, 7, 8, 6], [1, 2, 3, 8, 5, 7],
                  [8, 7, 6, 1, 4, 2], [5, 8, 7, 2, 1, 3], [6, 5, 8, 3, 2, 4], [7, 6, 5, 4, 3, 1]], dtype=np.int64) - 1
#: columns of the hourglass stiffness table (:func:`hourglass_stiffness`)
N_HGK = 18
#: hourglass state columns: q (4 modes x 3) then G (4 x 3)
N_HQ = 24


@numba.njit(cache=True)
def fb_gradient(x, y, z):
    """Flanagan & Belytschko's B_iI = dV/dx_iI (module docstring) of the hexahedron with nodal coordinates
    x, y, z (8 each); returns (B (3, 8), V)."""
    B = np.empty((3, 8))
    for comp in range(3):
        if comp == 0:
            yy, zz = y, z
        elif comp == 1:
            yy, zz = z, x
        else:
            yy, zz = x, y
        for I in range(8):
            n2 = _PERM[I, 0]
            n3 = _PERM[I, 1]
            n4 = _PERM[I, 2]
            n5 = _PERM[I, 3]
            n6 = _PERM[I, 4]
            n8 = _PERM[I, 5]
            B[comp, I] = (yy[n2] * ((zz[n6] - zz[n3]) - (zz[n4] - zz[n5])) + yy[n3] * (zz[n2] - zz[n4])
                          + yy[n4] * ((zz[n3] - zz[n8]) - (zz[n5] - zz[n2]))
                          + yy[n5] * ((zz[n8] - zz[n6]) - (zz[n2] - zz[n4])) + yy[n6] * (zz[n5] - zz[n2])
                          + yy[n8] * (zz[n4] - zz[n5])) / 12.0
    V = 0.0
    for I in range(8):
        V += B[0, I] * x[I]
    return B, V


@numba.njit(cache=True)
def _frame(x, y, z, V):
    """Element axes (rows t1, t2, t3) and half-lengths a, b, c of the reference element (module docstring)."""
    g = np.zeros((3, 3))
    for I in range(8):
        for k in range(3):
            g[k, 0] += 0.125 * XI[I, k] * x[I]
            g[k, 1] += 0.125 * XI[I, k] * y[I]
            g[k, 2] += 0.125 * XI[I, k] * z[I]
    T = np.zeros((3, 3))
    a = math.sqrt(g[0, 0] ** 2 + g[0, 1] ** 2 + g[0, 2] ** 2)
    for j in range(3):
        T[0, j] = g[0, j] / a
    d = g[1, 0] * T[0, 0] + g[1, 1] * T[0, 1] + g[1, 2] * T[0, 2]
    for j in range(3):
        T[1, j] = g[1, j] - d * T[0, j]
    b = math.sqrt(T[1, 0] ** 2 + T[1, 1] ** 2 + T[1, 2] ** 2)
    for j in range(3):
        T[1, j] /= b
    T[2, 0] = T[0, 1] * T[1, 2] - T[0, 2] * T[1, 1]
    T[2, 1] = T[0, 2] * T[1, 0] - T[0, 0] * T[1, 2]
    T[2, 2] = T[0, 0] * T[1, 1] - T[0, 1] * T[1, 0]
    c = V / (8.0 * a * b)
    return T, a, b, c


@numba.njit(cache=True)
def _rotated_compliance(S4, m, T, a, b, c, d):
    """The component S'_abcd = T_ap T_bq T_cr T_dt S_pqrt of the material's compliance tensor S4[m] in the frame
    whose axes are the rows of T (the tensor transformation rule of a fourth-order tensor)."""
    s = 0.0
    for p in range(3):
        for q in range(3):
            for r in range(3):
                for t in range(3):
                    s += T[a, p] * T[b, q] * T[c, r] * T[d, t] * S4[m, p, q, r, t]
    return s


@numba.njit(cache=True)
def _compliance_in_frame(S4, m, T):
    """Normal compliances s_kl and engineering shear compliances (1/G12, 1/G23, 1/G31) of the material's
    compliance tensor S4[m] (3, 3, 3, 3) in the frame whose axes are the rows of T."""
    out = np.zeros((3, 3))
    sh = np.zeros(3)
    pairs = ((0, 1), (1, 2), (2, 0))
    for i in range(3):
        for k in range(3):
            out[i, k] = _rotated_compliance(S4, m, T, i, i, k, k)
    for n in range(3):
        i, j = pairs[n]
        sh[n] = 4.0 * _rotated_compliance(S4, m, T, i, j, i, j)
    return out, sh


@numba.njit(cache=True)
def _block(s11, s12, s22, v3, l1, l2):
    """(V/3) diag(1/l1, 1/l2) inv([[s11, s12], [s12, s22]]) diag(1/l1, 1/l2) as (k11, k12, k22)."""
    det = s11 * s22 - s12 * s12
    return (v3 * s22 / det / (l1 * l1), -v3 * s12 / det / (l1 * l2), v3 * s11 / det / (l2 * l2))


@numba.njit(cache=True)
def reference_setup(X, hexes, mat, S4, rho, cmax, zeta_hg, b0, vol0, hx, axes, hgk, hvis, dte):
    """Per element: b0 (24: b_x of the 8 nodes, then b_y, b_z), V0, hx (12: Gamma_a . X_i), axes (9: rows t1,
    t2, t3), the hourglass stiffness table hgk (N_HGK columns, module docstring), the viscous coefficient
    hvis and the critical step dte. Returns the index of the first element with V0 <= 0 (or -1)."""
    ne = hexes.shape[0]
    bad = -1
    for e in range(ne):
        x = np.empty(8)
        y = np.empty(8)
        z = np.empty(8)
        for I in range(8):
            n = hexes[e, I]
            x[I] = X[0, n]
            y[I] = X[1, n]
            z[I] = X[2, n]
        B, V = fb_gradient(x, y, z)
        if not V > 0.0:
            if bad < 0:
                bad = e
            continue
        vol0[e] = V
        bb = 0.0
        for i in range(3):
            for I in range(8):
                b0[e, 8 * i + I] = B[i, I] / V
                bb += (B[i, I] / V) ** 2
        for a in range(4):
            hx[e, 3 * a] = 0.0
            hx[e, 3 * a + 1] = 0.0
            hx[e, 3 * a + 2] = 0.0
            for I in range(8):
                hx[e, 3 * a] += HG[a, I] * x[I]
                hx[e, 3 * a + 1] += HG[a, I] * y[I]
                hx[e, 3 * a + 2] += HG[a, I] * z[I]
        T, la, lb, lc = _frame(x, y, z, V)
        for i in range(3):
            for j in range(3):
                axes[e, 3 * i + j] = T[i, j]
        m = mat[e]
        s, sh = _compliance_in_frame(S4, m, T)
        v3 = V / 3.0
        k = _block(s[0, 0], s[0, 1], s[1, 1], v3, la, lb)  # zeta-linear: e11, e22
        hgk[e, 0] = k[0]
        hgk[e, 1] = k[1]
        hgk[e, 2] = k[2]
        k = _block(s[0, 0], s[0, 2], s[2, 2], v3, la, lc)  # eta-linear: e11, e33
        hgk[e, 3] = k[0]
        hgk[e, 4] = k[1]
        hgk[e, 5] = k[2]
        k = _block(s[1, 1], s[1, 2], s[2, 2], v3, lb, lc)  # xi-linear: e22, e33
        hgk[e, 6] = k[0]
        hgk[e, 7] = k[1]
        hgk[e, 8] = k[2]
        g12 = v3 / sh[0]
        g23 = v3 / sh[1]
        g31 = v3 / sh[2]
        ia, ib, ic = 1.0 / la, 1.0 / lb, 1.0 / lc
        # K = G12 u u^T + G31 w w^T + G23 s s^T, u = (1/b, 1/a, 0), w = (1/c, 0, 1/a), s = (0, 1/c, 1/b)
        hgk[e, 9] = g12 * ib * ib + g31 * ic * ic
        hgk[e, 10] = g12 * ib * ia
        hgk[e, 11] = g31 * ic * ia
        hgk[e, 12] = g12 * ia * ia + g23 * ic * ic
        hgk[e, 13] = g23 * ic * ib
        hgk[e, 14] = g31 * ia * ia + g23 * ib * ib
        hgk[e, 15] = V / (9.0 * s[0, 0] * la * la)
        hgk[e, 16] = V / (9.0 * s[1, 1] * lb * lb)
        hgk[e, 17] = V / (9.0 * s[2, 2] * lc * lc)
        # the largest eigenvalue of the hourglass stiffness (blocks: 2x2 closed form, 3x3 bounded by Gershgorin)
        kmax = 0.0
        for o in range(0, 9, 3):
            tr = hgk[e, o] + hgk[e, o + 2]
            dd = hgk[e, o] - hgk[e, o + 2]
            lam = 0.5 * tr + math.sqrt(0.25 * dd * dd + hgk[e, o + 1] ** 2)
            kmax = max(kmax, lam)
        kt = max(hgk[e, 9] + abs(hgk[e, 10]) + abs(hgk[e, 11]), abs(hgk[e, 10]) + hgk[e, 12] + abs(hgk[e, 13]),
                 abs(hgk[e, 11]) + abs(hgk[e, 13]) + hgk[e, 14])
        kmax = max(kmax, kt, hgk[e, 15], hgk[e, 16], hgk[e, 17])
        gmax = 0.0
        for a in range(4):
            row = 0.0
            for c2 in range(4):
                gg = 0.0
                for I in range(8):
                    ga = 0.125 * (HG[a, I] - (hx[e, 3 * a] * B[0, I] + hx[e, 3 * a + 1] * B[1, I]
                                              + hx[e, 3 * a + 2] * B[2, I]) / V)
                    gc = 0.125 * (HG[c2, I] - (hx[e, 3 * c2] * B[0, I] + hx[e, 3 * c2 + 1] * B[1, I]
                                               + hx[e, 3 * c2 + 2] * B[2, I]) / V)
                    gg += ga * gc
                row += abs(gg)
            gmax = max(gmax, row)
        mass = rho[m] * V
        w2 = 8.0 * cmax[m] ** 2 * bb + 8.0 * kmax * gmax / mass
        dte[e] = 2.0 / math.sqrt(w2)
        hvis[e] = 2.0 * zeta_hg * math.sqrt(mass * kmax)
    return bad


@numba.njit(cache=True, inline="always")
def polar_rotation(f00, f01, f02, f10, f11, f12, f20, f21, f22):
    """The rotation R of F = R U by Newton's iteration R <- (R + R^-T) / 2 (Higham 1986, SIAM J. Sci.
    Stat. Comput. 7:1160), quadratic from R = F; returns R row by row and det F."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = f00, f01, f02, f10, f11, f12, f20, f21, f22
    det0 = (f00 * (f11 * f22 - f12 * f21) - f01 * (f10 * f22 - f12 * f20) + f02 * (f10 * f21 - f11 * f20))
    if not det0 > 0.0:
        return 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, det0
    for _ in range(30):
        c00 = r11 * r22 - r12 * r21
        c01 = r12 * r20 - r10 * r22
        c02 = r10 * r21 - r11 * r20
        c10 = r02 * r21 - r01 * r22
        c11 = r00 * r22 - r02 * r20
        c12 = r01 * r20 - r00 * r21
        c20 = r01 * r12 - r02 * r11
        c21 = r02 * r10 - r00 * r12
        c22 = r00 * r11 - r01 * r10
        idet = 1.0 / (r00 * c00 + r01 * c01 + r02 * c02)  # R^-T = cofactor / det
        n00 = 0.5 * (r00 + c00 * idet)
        n01 = 0.5 * (r01 + c01 * idet)
        n02 = 0.5 * (r02 + c02 * idet)
        n10 = 0.5 * (r10 + c10 * idet)
        n11 = 0.5 * (r11 + c11 * idet)
        n12 = 0.5 * (r12 + c12 * idet)
        n20 = 0.5 * (r20 + c20 * idet)
        n21 = 0.5 * (r21 + c21 * idet)
        n22 = 0.5 * (r22 + c22 * idet)
        d = (abs(n00 - r00) + abs(n01 - r01) + abs(n02 - r02) + abs(n10 - r10) + abs(n11 - r11)
             + abs(n12 - r12) + abs(n20 - r20) + abs(n21 - r21) + abs(n22 - r22))
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = n00, n01, n02, n10, n11, n12, n20, n21, n22
        if d < 1e-13:
            break
    return r00, r01, r02, r10, r11, r12, r20, r21, r22, det0


@numba.njit(cache=True, inline="always")
def node_gradient(b0, e, I):
    """b0_iI of node I of element e (i = x, y, z): the reference element's mean gradient (module docstring)."""
    return b0[e, I], b0[e, 8 + I], b0[e, 16 + I]


@numba.njit(cache=True, inline="always")
def node_gammas(I, hv, bx, by, bz):
    """The hourglass gamma vectors' entries of node I, gamma_aI = (Gamma_aI - (Gamma_a . X_i) b0_iI) / 8,
    a = 0 .. 3 (Flanagan & Belytschko 1981; module docstring), from b0_iI = (bx, by, bz) and the element's
    Gamma_a . X_i row hv (row-major, 4 x 3)."""
    return (0.125 * (HG[0, I] - (hv[0] * bx + hv[1] * by + hv[2] * bz)),
            0.125 * (HG[1, I] - (hv[3] * bx + hv[4] * by + hv[5] * bz)),
            0.125 * (HG[2, I] - (hv[6] * bx + hv[7] * by + hv[8] * bz)),
            0.125 * (HG[3, I] - (hv[9] * bx + hv[10] * by + hv[11] * bz)))


@numba.njit(cache=True, inline="always")
def nodal_sums(u, hexes, b0, hv, e):
    """sum_I u_iI b0_jI (row-major) and the hourglass amplitudes sum_I gamma_aI u_I (a = 0 .. 3, row-major)
    of the nodal field u (3, n) over element e: the deformation gradient F and q_a when u = x, the
    velocity gradient in the reference frame and dq_a/dt when u = v (Flanagan & Belytschko 1981; module
    docstring). Returns the 9 + 12 sums."""
    f00 = f01 = f02 = f10 = f11 = f12 = f20 = f21 = f22 = 0.0
    q00 = q01 = q02 = q10 = q11 = q12 = q20 = q21 = q22 = q30 = q31 = q32 = 0.0
    for I in range(8):
        n = hexes[e, I]
        bx, by, bz = node_gradient(b0, e, I)
        px = u[0, n]
        py = u[1, n]
        pz = u[2, n]
        f00 += px * bx
        f01 += px * by
        f02 += px * bz
        f10 += py * bx
        f11 += py * by
        f12 += py * bz
        f20 += pz * bx
        f21 += pz * by
        f22 += pz * bz
        g0, g1, g2, g3 = node_gammas(I, hv, bx, by, bz)
        q00 += g0 * px
        q01 += g0 * py
        q02 += g0 * pz
        q10 += g1 * px
        q11 += g1 * py
        q12 += g1 * pz
        q20 += g2 * px
        q21 += g2 * py
        q22 += g2 * pz
        q30 += g3 * px
        q31 += g3 * py
        q32 += g3 * pz
    return f00, f01, f02, f10, f11, f12, f20, f21, f22, q00, q01, q02, q10, q11, q12, q20, q21, q22, q30, q31, q32


@numba.njit(cache=True, inline="always")
def mat_vec(m, a0, a1, a2):
    """m a for the row-major 3x3 m: the rotations of the hourglass amplitudes and forces between the current
    frame and the element axes, Q_a = M q_a and G_a = M^T Gq_a with M = T R^T (module docstring)."""
    return m[0] * a0 + m[1] * a1 + m[2] * a2, m[3] * a0 + m[4] * a1 + m[5] * a2, m[6] * a0 + m[7] * a1 + m[8] * a2


@numba.njit(cache=True, inline="always")
def hourglass_scale(cmat, m, exx, eyy, ezz, exy, eyz, ezx, sxx, syy, szz, sxy, syz, szx):
    """The factor on an inelastic element's hourglass stiffness: its centre's secant ratio
    s = |S| / |C : E| (Frobenius norms, tensor shears), 1 while the centre is elastic, below 1 once it has
    flowed plastically, softened or been damaged, and 1 for a strain below 1e-9.

    The assumed-strain modes stand for the linear part of the strain over the element (module docstring),
    which the material law never sees; their stiffness is the elastic one. Where the centre flows, an
    elastic resistance to bending would store energy the material cannot hold (a fibre past Xc under the
    edge kept elastic in bending while its centre yields) and would make the element stiffer than the
    material. Scaling the stabilization with the material's current (secant) stiffness is our choice, after
    Belytschko & Bindeman 1993 (CMAME 105:225), whose stiffness is that of the material. The element keeps
    the smallest ratio it has had (``hist[e, H3_HGD]`` = 1 - s, non-decreasing, as a damage variable): the
    force s K Q with s never rising cannot give back more work than it took (a factor that rose again on
    unloading, when the centre's strain passes back through its plastic strain, created energy). The element
    applies max(s, :data:`solver.fem.quad.HOURGLASS_SECANT_FLOOR`): with no floor, the flowing compression side
    of a bent fibre loses its control (docs/numerics.md, "The 2D quad's hourglass in inelastic elements")."""
    t0, t1, t2, t3, t4, t5 = pk2_stress(cmat, m, exx, eyy, ezz, exy, eyz, ezx)
    trial = t0 * t0 + t1 * t1 + t2 * t2 + 2.0 * (t3 * t3 + t4 * t4 + t5 * t5)
    strain = exx * exx + eyy * eyy + ezz * ezz + 2.0 * (exy * exy + eyz * eyz + ezx * ezx)
    if strain < 1e-18 or trial <= 0.0:
        return 1.0
    s = math.sqrt((sxx * sxx + syy * syy + szz * szz + 2.0 * (sxy * sxy + syz * syz + szx * szx)) / trial)
    return s if s < 1.0 else 1.0


@numba.njit(cache=True, inline="always")
def hex8_update(e, hexes, b0, vol0, hx, axes, hgk, hvis, x, v, cmat, props, mat, hist, check, pk2, strain, eint, ehg, hq,
                fe):
    """One element's stress update and nodal forces at the current positions x (3, n).

    Writes the 24 nodal forces (x0, y0, z0, x1, ...; force ON the nodes = minus the internal force)
    into fe[e], the 2nd Piola-Kirchhoff stress and the Green-Lagrange strain (xx, yy, zz, xy, yz, zx,
    tensor shears) into pk2[e], strain[e]; adds the stress work V0 (S_old + S_new)/2 : (E_new - E_old)
    to eint[e] and the hourglass work (G_old + G_new)/2 . (q_new - q_old) to ehg[e] (hq[e] keeps q and
    G of the last step). v (3, n) is read only when the viscous hourglass is on (hvis[e] > 0).
    The stress comes from the element's material law (:mod:`.laws3d`; the elastic kind S = C : E directly),
    which may update the element's history row hist[e] and, when ``check``, return a failure mode.
    Returns (1 when det F <= 0 (inverted element) else 0, the law's failure mode).
    """
    V0 = vol0[e]
    hv = (hx[e, 0], hx[e, 1], hx[e, 2], hx[e, 3], hx[e, 4], hx[e, 5], hx[e, 6], hx[e, 7], hx[e, 8], hx[e, 9],
          hx[e, 10], hx[e, 11])
    (f00, f01, f02, f10, f11, f12, f20, f21, f22,
     q00, q01, q02, q10, q11, q12, q20, q21, q22, q30, q31, q32) = nodal_sums(x, hexes, b0, hv, e)
    # Green-Lagrange strain E = (F^T F - I) / 2 (tensor shears)
    exx = 0.5 * (f00 * f00 + f10 * f10 + f20 * f20 - 1.0)
    eyy = 0.5 * (f01 * f01 + f11 * f11 + f21 * f21 - 1.0)
    ezz = 0.5 * (f02 * f02 + f12 * f12 + f22 * f22 - 1.0)
    exy = 0.5 * (f00 * f01 + f10 * f11 + f20 * f21)
    eyz = 0.5 * (f01 * f02 + f11 * f12 + f21 * f22)
    ezx = 0.5 * (f02 * f00 + f12 * f10 + f22 * f20)
    m = mat[e]
    hs = 1.0  # the hourglass stiffness's factor: the centre's smallest secant ratio, floored (hourglass_scale)
    if props[m, KIND] == ELASTIC_KIND:
        sxx, syy, szz, sxy, syz, szx = pk2_stress(cmat, m, exx, eyy, ezz, exy, eyz, ezx)
        mode = 0
    else:
        sxx, syy, szz, sxy, syz, szx, mode = law_stress(props, cmat, m, exx, eyy, ezz, exy, eyz, ezx, hist, e, V0,
                                                        check)
        d_hg = 1.0 - hourglass_scale(cmat, m, exx, eyy, ezz, exy, eyz, ezx, sxx, syy, szz, sxy, syz, szx)
        if d_hg > hist[e, H3_HGD]:  # non-decreasing, as a damage variable
            hist[e, H3_HGD] = d_hg
        hs = max(1.0 - hist[e, H3_HGD], HOURGLASS_SECANT_FLOOR)
    eint[e] += V0 * (0.5 * ((pk2[e, 0] + sxx) * (exx - strain[e, 0]) + (pk2[e, 1] + syy) * (eyy - strain[e, 1])
                            + (pk2[e, 2] + szz) * (ezz - strain[e, 2]))
                     + (pk2[e, 3] + sxy) * (exy - strain[e, 3]) + (pk2[e, 4] + syz) * (eyz - strain[e, 4])
                     + (pk2[e, 5] + szx) * (ezx - strain[e, 5]))
    pk2[e, 0] = sxx
    pk2[e, 1] = syy
    pk2[e, 2] = szz
    pk2[e, 3] = sxy
    pk2[e, 4] = syz
    pk2[e, 5] = szx
    strain[e, 0] = exx
    strain[e, 1] = eyy
    strain[e, 2] = ezz
    strain[e, 3] = exy
    strain[e, 4] = eyz
    strain[e, 5] = ezx
    # V0 P = V0 F S
    p00 = V0 * (f00 * sxx + f01 * sxy + f02 * szx)
    p01 = V0 * (f00 * sxy + f01 * syy + f02 * syz)
    p02 = V0 * (f00 * szx + f01 * syz + f02 * szz)
    p10 = V0 * (f10 * sxx + f11 * sxy + f12 * szx)
    p11 = V0 * (f10 * sxy + f11 * syy + f12 * syz)
    p12 = V0 * (f10 * szx + f11 * syz + f12 * szz)
    p20 = V0 * (f20 * sxx + f21 * sxy + f22 * szx)
    p21 = V0 * (f20 * sxy + f21 * syy + f22 * syz)
    p22 = V0 * (f20 * szx + f21 * syz + f22 * szz)
    # hourglass: M = T R^T maps a current-frame vector to the element axes
    r00, r01, r02, r10, r11, r12, r20, r21, r22, det = polar_rotation(f00, f01, f02, f10, f11, f12, f20, f21, f22)
    rm = (r00, r01, r02, r10, r11, r12, r20, r21, r22)
    m00, m01, m02 = mat_vec(rm, axes[e, 0], axes[e, 1], axes[e, 2])  # row k of M = R t_k
    m10, m11, m12 = mat_vec(rm, axes[e, 3], axes[e, 4], axes[e, 5])
    m20, m21, m22 = mat_vec(rm, axes[e, 6], axes[e, 7], axes[e, 8])
    mm = (m00, m01, m02, m10, m11, m12, m20, m21, m22)
    # Q[a][k] = M q_a
    Q00, Q01, Q02 = mat_vec(mm, q00, q01, q02)
    Q10, Q11, Q12 = mat_vec(mm, q10, q11, q12)
    Q20, Q21, Q22 = mat_vec(mm, q20, q21, q22)
    Q30, Q31, Q32 = mat_vec(mm, q30, q31, q32)
    # dW/dQ (module docstring): bending blocks, twist, xi eta zeta
    # (x hs: 1 for an elastic element, module docstring)
    G10 = hs * (hgk[e, 0] * Q10 + hgk[e, 1] * Q01)  # zeta-linear: (Q(xi zeta, t1), Q(eta zeta, t2))
    G01 = hs * (hgk[e, 1] * Q10 + hgk[e, 2] * Q01)
    G20 = hs * (hgk[e, 3] * Q20 + hgk[e, 4] * Q02)  # eta-linear: (Q(xi eta, t1), Q(eta zeta, t3))
    G02 = hs * (hgk[e, 4] * Q20 + hgk[e, 5] * Q02)
    G21 = hs * (hgk[e, 6] * Q21 + hgk[e, 7] * Q12)  # xi-linear: (Q(xi eta, t2), Q(xi zeta, t3))
    G12 = hs * (hgk[e, 7] * Q21 + hgk[e, 8] * Q12)
    G00 = hs * (hgk[e, 9] * Q00 + hgk[e, 10] * Q11 + hgk[e, 11] * Q22)  # twist
    G11 = hs * (hgk[e, 10] * Q00 + hgk[e, 12] * Q11 + hgk[e, 13] * Q22)
    G22 = hs * (hgk[e, 11] * Q00 + hgk[e, 13] * Q11 + hgk[e, 14] * Q22)
    G30 = hs * (hgk[e, 15] * Q30)
    G31 = hs * (hgk[e, 16] * Q31)
    G32 = hs * (hgk[e, 17] * Q32)
    cv = hvis[e]
    if cv > 0.0:  # viscous part: c dQ/dt with dQ/dt = M sum_I gamma_I v_I
        d00, d01, d02, d10, d11, d12, d20, d21, d22, d30, d31, d32 = nodal_sums(v, hexes, b0, hv, e)[9:]
        D00, D01, D02 = mat_vec(mm, d00, d01, d02)
        D10, D11, D12 = mat_vec(mm, d10, d11, d12)
        D20, D21, D22 = mat_vec(mm, d20, d21, d22)
        D30, D31, D32 = mat_vec(mm, d30, d31, d32)
        G00 += cv * D00
        G01 += cv * D01
        G02 += cv * D02
        G10 += cv * D10
        G11 += cv * D11
        G12 += cv * D12
        G20 += cv * D20
        G21 += cv * D21
        G22 += cv * D22
        G30 += cv * D30
        G31 += cv * D31
        G32 += cv * D32
    # back to the current frame: G_a = M^T Gq_a
    mt = (m00, m10, m20, m01, m11, m21, m02, m12, m22)
    a00, a01, a02 = mat_vec(mt, G00, G01, G02)
    a10, a11, a12 = mat_vec(mt, G10, G11, G12)
    a20, a21, a22 = mat_vec(mt, G20, G21, G22)
    a30, a31, a32 = mat_vec(mt, G30, G31, G32)
    ehg[e] += 0.5 * ((hq[e, 12] + a00) * (q00 - hq[e, 0]) + (hq[e, 13] + a01) * (q01 - hq[e, 1])
                     + (hq[e, 14] + a02) * (q02 - hq[e, 2]) + (hq[e, 15] + a10) * (q10 - hq[e, 3])
                     + (hq[e, 16] + a11) * (q11 - hq[e, 4]) + (hq[e, 17] + a12) * (q12 - hq[e, 5])
                     + (hq[e, 18] + a20) * (q20 - hq[e, 6]) + (hq[e, 19] + a21) * (q21 - hq[e, 7])
                     + (hq[e, 20] + a22) * (q22 - hq[e, 8]) + (hq[e, 21] + a30) * (q30 - hq[e, 9])
                     + (hq[e, 22] + a31) * (q31 - hq[e, 10]) + (hq[e, 23] + a32) * (q32 - hq[e, 11]))
    hq[e, 0] = q00
    hq[e, 1] = q01
    hq[e, 2] = q02
    hq[e, 3] = q10
    hq[e, 4] = q11
    hq[e, 5] = q12
    hq[e, 6] = q20
    hq[e, 7] = q21
    hq[e, 8] = q22
    hq[e, 9] = q30
    hq[e, 10] = q31
    hq[e, 11] = q32
    hq[e, 12] = a00
    hq[e, 13] = a01
    hq[e, 14] = a02
    hq[e, 15] = a10
    hq[e, 16] = a11
    hq[e, 17] = a12
    hq[e, 18] = a20
    hq[e, 19] = a21
    hq[e, 20] = a22
    hq[e, 21] = a30
    hq[e, 22] = a31
    hq[e, 23] = a32
    for I in range(8):
        bx, by, bz = node_gradient(b0, e, I)
        g0, g1, g2, g3 = node_gammas(I, hv, bx, by, bz)
        fe[e, 3 * I] = -(p00 * bx + p01 * by + p02 * bz + g0 * a00 + g1 * a10 + g2 * a20 + g3 * a30)
        fe[e, 3 * I + 1] = -(p10 * bx + p11 * by + p12 * bz + g0 * a01 + g1 * a11 + g2 * a21 + g3 * a31)
        fe[e, 3 * I + 2] = -(p20 * bx + p21 * by + p22 * bz + g0 * a02 + g1 * a12 + g2 * a22 + g3 * a32)
    return (1 if det <= 0.0 else 0), mode


def gamma_vectors(b0_row: np.ndarray, hx_row: np.ndarray) -> np.ndarray:
    """(4, 8) Flanagan-Belytschko hourglass vectors gamma_aI of one element from its b0 and hx rows."""
    b = np.asarray(b0_row).reshape(3, 8)
    h = np.asarray(hx_row).reshape(4, 3)
    return 0.125 * (HG - h @ b)


def velocity_gradient(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """L_ij = sum_I v_iI b_jI at the current configuration x (8, 3) with nodal velocities v (8, 3); the
    strain rate is its symmetric part (zero for every rigid motion)."""
    x = np.asarray(x, float)
    B, V = fb_gradient(np.ascontiguousarray(x[:, 0]), np.ascontiguousarray(x[:, 1]), np.ascontiguousarray(x[:, 2]))
    return np.asarray(v, float).T @ (B / V).T
