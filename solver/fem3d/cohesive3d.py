"""Zero-thickness 8-node cohesive interface elements of the 3D engine.

An element joins the node pairs (a_k, b_k), k = 0..3, that start at the same place; a0..a3 go round
the face (a quadrilateral, counter-clockwise or clockwise: the normal's sign ``csign`` is fixed at
build time so that n points from side A into side B). Its frame follows the current mid-surface
m_k = (x_ak + x_bk)/2: normal n = s unit(g1 x g2) with the diagonals g1 = m2 - m0, g2 = m3 - m1 (the
normal of a bilinear quadrilateral at its centre). Openings at the four node pairs (nodal
Newton-Cotes integration, weight w = A0/4 per point, A0 = |G1 x G2|/2 the reference area from the
reference diagonals; nodal rather than Gauss integration keeps the points from coupling and the
traction profile free of oscillations under steep gradients, Schellekens & de Borst 1993):

    delta = x_bk - x_ak,  delta_n = delta . n,  delta_s vector = delta - delta_n n,  delta_s = |delta_s vector|

The two tangential directions enter only through |delta_s| (the law is isotropic in the plane), so no
tangent basis is needed for the forces; :func:`tangents` gives one (t1 = unit(g1), t2 = n x t1) to
report the two tangential openings.

Law: the 2D element's bilinear mixed-mode law, :func:`solver.fem.cohesive_law.bilinear_damage` (Camanho
& Davila 2002, NASA/TM-2002-211737, eqs. 5-22, one penalty K for both modes, Benzeggagh & Kenane 1996
mixing; one function for both elements) with delta_s the magnitude of the tangential opening vector
(their 3D form, which the 2D element's scalar delta_s specialises), then

    traction T = t_n n + (1 - d) K delta_s vector, t_n = (1 - d) K delta_n (dn > 0) or K delta_n (closed:
            the undamaged penalty; a fully damaged point resists closing only while its slip is below
            half the element's size, sqrt(A0)/2, and only for a closing it saw happen: open or resisting
            at the last step, as the 2D element)

Free energy per point psi = (1/2) k_s |delta_s|^2 + psi_n(delta_n), k_s = (1 - d) K, psi_n = (1/2)(1 - d) K
<dn>^2 + (1/2) K <-dn>^2 (or (1/2) t_n dn for a debonded point still resisting). The nodal forces are
-d(w psi)/dx: F_b = -w T, F_a = w T at each pair, plus the frame forces, since n turns with the
nodes: d psi / d n = (t_n - k_s delta_n) delta (zero for an open point, where psi = (1/2)(1 - d) K |delta|^2
does not depend on n), and with q = sum_k w (t_n - k_s dn) delta_k, p = s (I - n n) q / |g1 x g2|,
d psi / d m2 = -d psi / d m0 = g2 x p, d psi / d m3 = -d psi / d m1 = p x g1, each shared equally by the
pair's two nodes. The forces then sum to zero and carry no moment (psi is invariant under rigid motions).

Energy booking (as the 2D element): the work done on the element, trapezoidal from its own nodal forces,
-(f^{n-1} + f^n)/2 . (x^n - x^{n-1}) (``cwork``); its free energy (:func:`cohesive3d_free_energy`); its
dissipation, -d psi / d d dd = w (1/2) K (<dn>^2 + ds^2) dd at each point (``cdis``; Camanho & Davila
2002 sec. 3). cwork - psi - cdis is the work no energy accounts for (the engine's energy error).

An element fails (state 1, debonded) when all four points are fully damaged; it then only resists
closing (the contact of the separated faces). An element whose faces have turned against each other by 90
degrees or more (their own normals no longer agree) debonds at once, its remaining free energy dissipated,
and resists nothing (:func:`solver.fem.cohesive_law.turned_apart`): the mid-surface that defines its frame
degenerates as the faces cross. State 2 (removed) applies no force.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..fem.cohesive_law import add_free_energy, bilinear_damage, turned_apart

CK, CSIGN, CTAU, CGIC, CGIIC, CETA = 0, 1, 2, 3, 4, 5
INTACT, DEBONDED, REMOVED = 0, 1, 2
#: per-point history columns of ``chist`` (nc, 4, N_CH): last normal opening, tangential opening
#: magnitude, normal traction, tangential traction magnitude
H_DN, H_DS, H_TN, H_TS = 0, 1, 2, 3
N_CH = 4


@numba.njit(cache=True, inline="always")
def _opposed(fc, c, a, b, hx, hy, hz):
    """The frame force pair of one diagonal (module docstring: d psi / d m2 = g2 x p on m2, minus it on m0; likewise
    m3, m1): -h into the columns a .. a + 2 of fc[c], +h into b .. b + 2."""
    fc[c, a] -= hx
    fc[c, a + 1] -= hy
    fc[c, a + 2] -= hz
    fc[c, b] += hx
    fc[c, b + 1] += hy
    fc[c, b + 2] += hz


@numba.njit(cache=True, inline="always")
def _face_normal(x, n0, n1, n2, n3):
    """(x_n2 - x_n0) x (x_n3 - x_n1): twice the area times the normal of the face n0 n1 n2 n3 (its diagonals)."""
    d1x = x[0, n2] - x[0, n0]
    d1y = x[1, n2] - x[1, n0]
    d1z = x[2, n2] - x[2, n0]
    d2x = x[0, n3] - x[0, n1]
    d2y = x[1, n3] - x[1, n1]
    d2z = x[2, n3] - x[2, n1]
    return d1y * d2z - d1z * d2y, d1z * d2x - d1x * d2z, d1x * d2y - d1y * d2x


@numba.njit(cache=True)
def cohesive3d_update(c, coh, csign, carea, cp, dmg, chist, cwork, cdis, cstate, x, v, dtprev, fc):
    """One element: openings, damage, tractions and nodal forces into fc[c] (module docstring).

    coh[c] = (a0, a1, a2, a3, b0, b1, b2, b3); fc[c] (24,) the forces on those nodes as (x, y, z)
    triples, holding f^{n-1} on entry; v is v^{n-1/2}. Adds the work done on the element over
    [x^{n-1}, x^n] to cwork[c] and the dissipation of the damage growth to cdis[c]. Returns 10 when the
    element has just become fully damaged (all four points), else 0.
    """
    if cstate[c] == REMOVED:
        for k in range(24):
            fc[c, k] = 0.0
        return 0
    wold = 0.0
    for k in range(8):
        nd = coh[c, k]
        wold += fc[c, 3 * k] * v[0, nd] + fc[c, 3 * k + 1] * v[1, nd] + fc[c, 3 * k + 2] * v[2, nd]
    # mid-surface diagonals g1 = m2 - m0, g2 = m3 - m1 (m_k = (x_ak + x_bk) / 2) and the normal
    a0 = coh[c, 0]
    a1 = coh[c, 1]
    a2 = coh[c, 2]
    a3 = coh[c, 3]
    b0 = coh[c, 4]
    b1 = coh[c, 5]
    b2 = coh[c, 6]
    b3 = coh[c, 7]
    g1x = 0.5 * (x[0, a2] + x[0, b2] - x[0, a0] - x[0, b0])
    g1y = 0.5 * (x[1, a2] + x[1, b2] - x[1, a0] - x[1, b0])
    g1z = 0.5 * (x[2, a2] + x[2, b2] - x[2, a0] - x[2, b0])
    g2x = 0.5 * (x[0, a3] + x[0, b3] - x[0, a1] - x[0, b1])
    g2y = 0.5 * (x[1, a3] + x[1, b3] - x[1, a1] - x[1, b1])
    g2z = 0.5 * (x[2, a3] + x[2, b3] - x[2, a1] - x[2, b1])
    gx = g1y * g2z - g1z * g2y
    gy = g1z * g2x - g1x * g2z
    gz = g1x * g2y - g1y * g2x
    gl = math.sqrt(gx * gx + gy * gy + gz * gz)
    if gl <= 0.0:
        gl = 1e-300
    s = csign[c]
    nx = s * gx / gl
    ny = s * gy / gl
    nz = s * gz / gl
    w = 0.25 * carea[c]
    slip_max = 0.5 * math.sqrt(carea[c])
    # the two faces turned against each other by 90 degrees or more (their own normals, from their own
    # diagonals, no longer agree): the mid-surface degenerates as they cross, and with it the normal and the
    # frame forces (which scale with 1 / |g1 x g2|); an intact element debonds at once, as the 2D one
    # (solver.fem.cohesive_law.turned_apart)
    nax, nay, naz = _face_normal(x, a0, a1, a2, a3)
    nbx, nby, nbz = _face_normal(x, b0, b1, b2, b3)
    turned = nax * nbx + nay * nby + naz * nbz <= 0.0
    K = cp[CK]
    qx = 0.0
    qy = 0.0
    qz = 0.0
    n_full = 0
    for k in range(4):
        a = coh[c, k]
        b = coh[c, 4 + k]
        dx = x[0, b] - x[0, a]
        dy = x[1, b] - x[1, a]
        dz = x[2, b] - x[2, a]
        dn = dx * nx + dy * ny + dz * nz
        sx = dx - dn * nx
        sy = dy - dn * ny
        sz = dz - dn * nz
        ds = math.sqrt(sx * sx + sy * sy + sz * sz)
        d = dmg[c, k]
        if cstate[c] == INTACT and turned:
            cdis[c] += turned_apart(dn, ds, d, K, w)
            d = 1.0
            dmg[c, k] = d
        elif cstate[c] == INTACT:
            dnew = bilinear_damage(dn, ds, d, K, cp[CSIGN] / K, cp[CTAU] / K, cp[CGIC], cp[CGIIC], cp[CETA])
            if dnew > d:
                dnp = dn if dn > 0.0 else 0.0
                cdis[c] += w * 0.5 * K * (dnp * dnp + ds * ds) * (dnew - d)
                d = dnew
                dmg[c, k] = d
        if d >= 1.0:
            n_full += 1
        ks = (1.0 - d) * K
        if dn > 0.0:
            tn = ks * dn
        elif d >= 1.0 and (turned or not (ds <= slip_max and (chist[c, k, H_DN] >= 0.0 or chist[c, k, H_TN] < 0.0))):
            tn = 0.0  # debonded, slid away, turned apart or met already overlapped: no longer this element's contact
        else:
            tn = K * dn
        chist[c, k, H_DN] = dn
        chist[c, k, H_DS] = ds
        chist[c, k, H_TN] = tn
        chist[c, k, H_TS] = ks * ds
        tx = tn * nx + ks * sx
        ty = tn * ny + ks * sy
        tz = tn * nz + ks * sz
        fc[c, 3 * k] = w * tx  # a_k
        fc[c, 3 * k + 1] = w * ty
        fc[c, 3 * k + 2] = w * tz
        fc[c, 12 + 3 * k] = -w * tx  # b_k
        fc[c, 13 + 3 * k] = -w * ty
        fc[c, 14 + 3 * k] = -w * tz
        cq = w * (tn - ks * dn)  # d psi / d n = (t_n - k_s dn) delta
        qx += cq * dx
        qy += cq * dy
        qz += cq * dz
    # frame forces: -d psi / d n . d n / d x through the diagonals (module docstring)
    if qx != 0.0 or qy != 0.0 or qz != 0.0:
        qn = qx * nx + qy * ny + qz * nz
        px = s * (qx - qn * nx) / gl
        py = s * (qy - qn * ny) / gl
        pz = s * (qz - qn * nz) / gl
        # d psi / d m2 = g2 x p, d psi / d m3 = p x g1 (and minus them on m0, m1), half on each node
        h2x = 0.5 * (g2y * pz - g2z * py)
        h2y = 0.5 * (g2z * px - g2x * pz)
        h2z = 0.5 * (g2x * py - g2y * px)
        h3x = 0.5 * (py * g1z - pz * g1y)
        h3y = 0.5 * (pz * g1x - px * g1z)
        h3z = 0.5 * (px * g1y - py * g1x)
        for side in range(2):
            o = 12 * side
            _opposed(fc, c, o + 6, o + 0, h2x, h2y, h2z)  # m2 and m0
            _opposed(fc, c, o + 9, o + 3, h3x, h3y, h3z)  # m3 and m1
    wnew = 0.0
    for k in range(8):
        nd = coh[c, k]
        wnew += fc[c, 3 * k] * v[0, nd] + fc[c, 3 * k + 1] * v[1, nd] + fc[c, 3 * k + 2] * v[2, nd]
    cwork[c] -= 0.5 * dtprev * (wold + wnew)
    if cstate[c] == INTACT and n_full == 4:
        cstate[c] = DEBONDED
        return 10
    return 0


@numba.njit(cache=True)
def cohesive3d_free_energy(c, carea, cp, dmg, chist):
    """Free energy stored in element c [J] at its last openings (module docstring;
    :func:`solver.fem.cohesive_law.add_free_energy` per point)."""
    K = cp[CK]
    e = 0.0
    for k in range(4):
        e = add_free_energy(e, chist[c, k, H_DN], chist[c, k, H_DS], dmg[c, k], K, chist[c, k, H_TN])
    return 0.25 * carea[c] * e


def cohesive_props(K, sigma_n, tau, GIc, GIIc, eta) -> np.ndarray:
    """[K, sigma_n, tau, G_Ic, G_IIc, eta] (SI: Pa/m, Pa, Pa, J/m^2, J/m^2, -)."""
    return np.array([K, sigma_n, tau, GIc, GIIc, eta], dtype=np.float64)


def cohesive3d_geometry(X, coh, hexes, nptr=None, nidx=None):
    """Reference areas A0 and normal signs s (n points from side A into side B) of the elements.

    The sign comes from the centroid of a hexahedron holding node b0 (side B). Raises ValueError when a
    node pair does not start at the same place, an area is zero, or b0 belongs to no hexahedron.
    """
    coh = np.asarray(coh)
    nc = coh.shape[0]
    if nc == 0:
        return np.zeros(0), np.ones(0)
    A = X[:, coh[:, :4]]  # (3, nc, 4)
    B = X[:, coh[:, 4:]]
    mid = 0.5 * (A + B)
    g1 = mid[:, :, 2] - mid[:, :, 0]
    g2 = mid[:, :, 3] - mid[:, :, 1]
    g = np.cross(g1.T, g2.T)  # (nc, 3)
    gl = np.linalg.norm(g, axis=1)
    area = 0.5 * gl
    if np.any(area <= 0):
        raise ValueError(f"cohesive element {int(np.argmin(area))} has zero area")
    gap = np.linalg.norm(B - A, axis=0).max(axis=1)
    if np.any(gap > 1e-9 * np.sqrt(area)):
        raise ValueError(f"cohesive element {int(np.argmax(gap))}: node pairs (a_k, b_k) must start at the same place")
    n = g / gl[:, None]
    cen = mid.mean(axis=2).T  # (nc, 3)
    holder = {}
    hexes = np.asarray(hexes)
    b0 = coh[:, 4]
    want = set(int(i) for i in b0)
    for e, row in enumerate(hexes):
        for nd in row:
            if int(nd) in want and int(nd) not in holder:
                holder[int(nd)] = e
    sign = np.ones(nc)
    for c in range(nc):
        e = holder.get(int(b0[c]))
        if e is None:
            raise ValueError(f"cohesive element {c}: node b0 = {int(b0[c])} belongs to no hexahedron")
        side = (X[:, hexes[e]].mean(axis=1) - cen[c]) @ n[c]
        sign[c] = 1.0 if side > 0 else -1.0
    return area, sign


def tangents(x, coh, csign):
    """(nc, 3, 3) current frames (n, t1, t2) of the elements: t1 = unit(g1), t2 = n x t1 (module docstring)."""
    A = x[:, coh[:, :4]]
    B = x[:, coh[:, 4:]]
    mid = 0.5 * (A + B)
    g1 = (mid[:, :, 2] - mid[:, :, 0]).T
    g2 = (mid[:, :, 3] - mid[:, :, 1]).T
    g = np.cross(g1, g2)
    n = csign[:, None] * g / np.linalg.norm(g, axis=1)[:, None]
    t1 = g1 / np.linalg.norm(g1, axis=1)[:, None]
    t2 = np.cross(n, t1)
    return np.stack([n, t1, t2], axis=1)
