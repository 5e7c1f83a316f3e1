"""Zero-thickness 4-node cohesive interface elements (fibre-matrix interface).

A cohesive element joins the node pairs (a0, b0) and (a1, b1) that start at the same place.
Its frame follows the current mid-line m_k = (x_ak + x_bk)/2: tangent t = unit(m1 - m0),
normal n = s (-t_y, t_x) with the sign s chosen at build time so that n points from side A
into side B. Openings at the two end points (nodal / Newton-Cotes integration, weight L0/2 per
point and unit width): delta_n = (x_b - x_a).n, delta_s = (x_b - x_a).t.

Bilinear traction-separation, mixed mode after Camanho & Davila 2002 (NASA/TM-2002-211737),
with one penalty K for both modes (their eqs. 5-22; Benzeggagh & Kenane 1996 mixing): the damage
d(delta_n, delta_s), irreversible, from :func:`solver.fem.cohesive_law.bilinear_damage` (the law of
the 3D element too), then

    traction t_s = (1 - d) K delta_s, t_n = (1 - d) K delta_n (dn > 0) or K delta_n (closed:
            no interpenetration, undamaged penalty; once fully damaged only while the faces still
            face each other: |delta_s| <= L0/2 and turned by less than 60 degrees, and only for a
            closing that happened while they did: open or resisting at the last step)

An element whose two faces have turned against each other by 90 degrees or more (their edges no longer
point the same way) debonds at once, its remaining free energy dissipated (:func:`turned_apart`): the
mid-line that defines its frame degenerates as the faces cross. An element fails when both points are
fully damaged (mode 10; it still resists closing, which
is the contact between the separated fibre and matrix, until fragment contact takes over) or when a bulk element it is tied to is
deleted (mode 11; it is removed entirely: the paper's "a matrix failure causes the deletion
of linked cohesive elements"). Nodal forces: F_b = -w (t_n n + t_s t), F_a = -F_b, plus the
frame forces: the forces are -d psi / dx of the free energy
psi = w sum_k [(1/2)(1 - d) K (<dn>^2 + ds^2) + (1/2) K <-dn>^2], and the openings are measured
in a frame that turns with the nodes, which adds -(d psi / d theta) d theta / dx
(:func:`cohesive_update`). Many explicit codes leave that term out; it vanishes for an isotropic
law, but a closed, damaged element (normal stiffness K, shear (1 - d) K) that turns then does
work its energy does not account for, and its forces carry a net moment. Here every point has
its frame forces; what the cohesive forces do beyond their free energy and dissipation is
``cohesive_unaccounted`` in :mod:`.energy`, part of the energy error.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .cohesive_law import add_free_energy, bilinear_damage, turned_apart
from .nodalwork import nodal_power, withdraw_forces

CK, CSIGN, CTAU, CGIC, CGIIC, CETA = 0, 1, 2, 3, 4, 5
INTACT, DEBONDED, REMOVED = 0, 1, 2


def cohesive_props(si) -> np.ndarray:
    """[K, sigma_n, tau, G_Ic, G_IIc, eta] in SI from ``si.interface``."""
    it = si.interface
    return np.array([it.K, it.sigma_n, it.tau, it.GIc, it.GIIc, it.eta], dtype=np.float64)


def cohesive_geometry(X, Y, quads, coh, coh_elems):
    """Reference length L0 and the normal's sign s (n points from side A into side B).

    The side-B element is the neighbour in ``coh_elems`` whose quad holds node b0; its centroid
    fixes the sign. Raises ValueError when the two node pairs do not start at the same place.
    """
    nc = coh.shape[0]
    if nc == 0:
        return np.zeros(0), np.ones(0)
    a0, a1, b0, b1 = coh[:, 0], coh[:, 1], coh[:, 2], coh[:, 3]
    gap = np.maximum(np.hypot(X[a0] - X[b0], Y[a0] - Y[b0]), np.hypot(X[a1] - X[b1], Y[a1] - Y[b1]))
    L0 = np.hypot(X[a1] - X[a0], Y[a1] - Y[a0])
    if np.any(L0 <= 0):
        raise ValueError(f"cohesive element {int(np.argmin(L0))} has zero length")
    if np.any(gap > 1e-9 * L0):
        raise ValueError(f"cohesive element {int(np.argmax(gap / L0))}: node pairs (a0, b0), (a1, b1) must start at the same place")
    tx, ty = (X[a1] - X[a0]) / L0, (Y[a1] - Y[a0]) / L0
    nx, ny = -ty, tx
    mx, my = 0.5 * (X[a0] + X[a1]), 0.5 * (Y[a0] + Y[a1])
    sign = np.ones(nc)
    for c in range(nc):
        done = False
        for k in range(2):
            el = int(coh_elems[c, k])
            if el < 0:
                continue
            q = quads[el]
            cx, cy = X[q].mean(), Y[q].mean()
            side = (cx - mx[c]) * nx[c] + (cy - my[c]) * ny[c]
            on_b = b0[c] in q
            sign[c] = (1.0 if side > 0 else -1.0) * (1.0 if on_b else -1.0)
            done = True
            break
        if not done:
            raise ValueError(f"cohesive element {c} has no bulk neighbour in cohesive_elems")
    return L0, sign


@numba.njit(cache=True, inline="always")
def cohesive_update(c, coh, coh_elems, alive, px, py, vx, vy, dtprev, csign, cL0, cp, dmg, cdn, cds, ctn, cts, wcoh,
                    cdis, cstate, fc):
    """One cohesive element: openings, damage, tractions, nodal forces into fc[c] (module docstring).

    fc[c] holds the forces on (a0, a1, b0, b1) as (x, y) pairs. Adds the work done on the element,
    -(f^{n-1} + f^n)/2 . (x^n - x^{n-1}) over its four nodes, to wcoh[c]. Returns the failure mode to
    record: 0 none, 10 fully damaged (this step), 11 a tied bulk element was deleted.
    Adds the energy dissipated by damage growth to cdis[c]: at each of the two points, with the free
    energy psi = (1/2)(1 - d) K (<dn>^2 + ds^2) + (1/2) K <-dn>^2 (<.> the positive part), the
    dissipation is -dpsi/dd dd = (1/2) K (<dn>^2 + ds^2) dd (Camanho & Davila 2002, sec. 3), times
    the point's weight L0 / 2. wcoh[c] - psi - cdis[c] is then the work the element's forces did
    that neither its free energy nor its damage accounts for (:mod:`.energy`).
    fc[c] holds f^{n-1} on entry (the work's trapezoid needs it); vx, vy are v^{n-1/2}.
    """
    if cstate[c] == 2:
        for k in range(8):
            fc[c, k] = 0.0
        return 0
    # the work done on the element over [x^{n-1}, x^n] is booked from the nodal forces themselves,
    # trapezoidal: -(1/2)(f^{n-1} + f^n) . (x^n - x^{n-1}), x^n - x^{n-1} = dt_prev v^{n-1/2}
    # (the rule the central difference's kinetic energy obeys, so the balance closes exactly; a
    # traction-opening integral in the rotating frame misses the frame's rotation)
    e0 = coh_elems[c, 0]
    e1 = coh_elems[c, 1]
    tied_deleted = (e0 >= 0 and alive[e0] == 0) or (e1 >= 0 and alive[e1] == 0)
    wold = nodal_power(fc, c, coh, vx, vy)
    a0 = coh[c, 0]
    a1 = coh[c, 1]
    b0 = coh[c, 2]
    b1 = coh[c, 3]
    mx0 = 0.5 * (px[a0] + px[b0])
    my0 = 0.5 * (py[a0] + py[b0])
    tx = 0.5 * (px[a1] + px[b1]) - mx0
    ty = 0.5 * (py[a1] + py[b1]) - my0
    tl = math.sqrt(tx * tx + ty * ty)
    if tl <= 0.0:
        tl = 1e-300
    tx /= tl
    ty /= tl
    nx = -csign[c] * ty
    ny = csign[c] * tx
    w = 0.5 * cL0[c]
    K = cp[CK]
    d0n = cp[CSIGN] / K
    d0s = cp[CTAU] / K
    mode = 0
    n_full = 0
    mom = 0.0  # M = w sum_k (t_s dn - t_n ds): the tractions' moment about the frame (frame forces below)
    # a debonded element still keeps its faces from closing while they face each other: slid by at
    # most L0/2 and turned by less than 60 degrees against each other (beyond, the mid-line that
    # defines the frame degenerates, and fragment contact takes over)
    eax = px[coh[c, 1]] - px[coh[c, 0]]
    eay = py[coh[c, 1]] - py[coh[c, 0]]
    ebx = px[coh[c, 3]] - px[coh[c, 2]]
    eby = py[coh[c, 3]] - py[coh[c, 2]]
    edges_dot = eax * ebx + eay * eby
    facing = edges_dot > 0.5 * math.sqrt((eax * eax + eay * eay) * (ebx * ebx + eby * eby))
    # faces turned against each other by 90 degrees or more: the mid-line, the mean of the two faces' edges,
    # shortens towards zero as they cross, and the frame it defines degenerates (the frame forces scale with
    # 1 / |m1 - m0|: a crossed element launched its nodes at 10 km/s in one step); an interface cannot be
    # intact between faces turned that far apart, so an intact element debonds at once (turned_apart)
    turned = edges_dot <= 0.0
    for k in range(2):
        a = coh[c, k]
        b = coh[c, 2 + k]
        dx = px[b] - px[a]
        dy = py[b] - py[a]
        dn = dx * nx + dy * ny
        ds = dx * tx + dy * ty
        d = dmg[c, k]
        if cstate[c] == 0 and not tied_deleted:  # (an element being removed does not damage further)
            if turned:
                cdis[c] += turned_apart(dn, ds, d, K, w)
                d = 1.0
                dmg[c, k] = d
            else:
                dnew = bilinear_damage(dn, ds, d, K, d0n, d0s, cp[CGIC], cp[CGIIC], cp[CETA])
                if dnew > d:
                    dnp = dn if dn > 0.0 else 0.0
                    cdis[c] += 0.25 * cL0[c] * K * (dnp * dnp + ds * ds) * (dnew - d)
                    d = dnew
                    dmg[c, k] = d
        if d >= 1.0:
            n_full += 1
        ts = (1.0 - d) * K * ds
        if dn > 0.0:
            tn = (1.0 - d) * K * dn
        elif d >= 1.0 and not (facing and abs(ds) <= 0.5 * cL0[c] and (cdn[c, k] >= 0.0 or ctn[c, k] < 0.0)):
            # debonded and no longer facing its partner: fragment contact's job. Nor does it take up
            # a closing it did not see happen: a point that comes back to facing already overlapped
            # (it was open or resisting at the last step only if cdn >= 0 or ctn < 0 there) would
            # meet the full penalty K dn at once, microns deep, and be launched (full 0-degree scene
            # with the mass-scaled tool contact: 0.24 J/m in one sample, 29 % energy error)
            tn = 0.0
        else:
            tn = K * dn
        cdn[c, k] = dn
        cds[c, k] = ds
        ctn[c, k] = tn
        cts[c, k] = ts
        fxb = -w * (tn * nx + ts * tx)
        fyb = -w * (tn * ny + ts * ty)
        fc[c, 2 * k] = -fxb
        fc[c, 2 * k + 1] = -fyb
        fc[c, 4 + 2 * k] = fxb
        fc[c, 5 + 2 * k] = fyb
        mom += w * (ts * dn - tn * ds)
    # frame forces: the openings are measured in the frame of the mid-line, which turns with the
    # nodes (theta, the tangent's angle, depends on m1 - m0); f = -d psi / dx then has the part
    # -(d psi / d theta) d theta / dx, with d psi / d theta = s M (s = csign) and
    # d theta / d m1 = -d theta / d m0 = (-t_y, t_x) / |m1 - m0|, shared by the two nodes of each
    # point. Without it a closed, damaged element (normal stiffness K, shear (1 - d) K) that turns
    # does work no energy accounts for, and its forces carry a net moment. Also for a fully damaged
    # point that still resists its closing (t_n = K dn, t_s = 0: M = -w K dn ds): a version without it
    # there (with it, converted particles had ended up inside fibre elements, before newborn
    # particles were placed on the boundary, solver.hybrid.coupler), and the debonded pairs' work showed
    # as cohesive_unaccounted: up to -0.017 J/m, 2.0-3.4 % energy errors in the full scenes.
    if mom != 0.0:
        g = csign[c] * mom / (2.0 * tl)
        gx = g * ty  # -g (-t_y, t_x): the force on each node of the a1/b1 end (the a0/b0 end: minus it)
        gy = -g * tx
        fc[c, 2] += gx  # a1
        fc[c, 3] += gy
        fc[c, 6] += gx  # b1
        fc[c, 7] += gy
        fc[c, 0] -= gx  # a0
        fc[c, 1] -= gy
        fc[c, 4] -= gx  # b0
        fc[c, 5] -= gy
    wnew = nodal_power(fc, c, coh, vx, vy)
    wcoh[c] -= 0.5 * dtprev * (wold + wnew)
    if cstate[c] == 0 and n_full == 2:
        mode = 10
    if tied_deleted:
        # a tied element was deleted: the work up to x^n is booked above, but f^n never acts: take back
        # (1/2) f^n . (x^n - x^{n-1}) (as for a deleted element), then no force acts any more
        wcoh[c] += withdraw_forces(fc, c, coh, vx, vy, dtprev)
        mode = 11
    return mode


@numba.njit(cache=True)
def cohesive_elastic_energy(c, cp, dmg, cdn, cds, ctn):
    """Recoverable energy stored in cohesive element c [J/m] (before the weight w): the free energy
    psi of the module docstring at the last openings (:func:`solver.fem.cohesive_law.add_free_energy`);
    a debonded point holds (1/2) t_n dn while its faces still resist closing (t_n = K dn,
    :func:`cohesive_update`), else nothing."""
    K = cp[CK]
    e = 0.0
    for k in range(2):
        e = add_free_energy(e, cdn[c, k], cds[c, k], dmg[c, k], K, ctn[c, k])
    return e
