"""The bilinear mixed-mode traction-separation law of the cohesive elements, written once for the 2D
(:mod:`solver.fem.cohesive`) and the 3D (:mod:`solver.fem3d.cohesive3d`) element.

Camanho & Davila 2002 (NASA/TM-2002-211737), eqs. 5-22, with one penalty K for both modes and the
Benzeggagh & Kenane 1996 mixing:

    delta_0n = N / K, delta_0s = S / K, delta_m = sqrt(<delta_n>^2 + delta_s^2)
    onset   delta_0m = delta_0n delta_0s sqrt((dn^2 + ds^2) / (dn^2 delta_0s^2 + ds^2 delta_0n^2))  (dn > 0)
    B-K     delta_fm = 2 / (K delta_0m) [G_Ic + (G_IIc - G_Ic) B^eta],  B = ds^2 / (dn^2 + ds^2)
            (for dn <= 0: delta_0m = delta_0s, delta_fm = 2 G_IIc / (K delta_0s))
    damage  d = max(d_old, delta_fm (delta_m - delta_0m) / (delta_m (delta_fm - delta_0m))), 0 <= d <= 1
            (irreversible)

delta_s is the tangential opening: a signed scalar in 2D, the magnitude of the tangential opening
vector in 3D (the law is isotropic in the plane; the 2D form is its specialisation). The elements
compute the tractions, the frame forces and the dissipation from the damage this returns, and sum
their points' free energy psi = (1/2)(1 - d) K (<dn>^2 + ds^2) + (1/2) K <-dn>^2 with
:func:`add_free_energy`.

The functions are inlined into their callers (``inline="always"``, at numba's IR level), so their
arithmetic is compiled with the caller's floating-point flags in the caller's operation order: the
2D chunk's fast-math build keeps the round-off it had when the law was written out in it. The
critical openings delta_0n, delta_0s are arguments, computed by the caller (once per element in 2D).
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always")
def bilinear_damage(dn, ds, d_old, K, d0n, d0s, GIc, GIIc, eta):
    """Damage after the opening (dn, ds) of the bilinear mixed-mode law (module docstring; Camanho &
    Davila 2002 eqs. 5-22 with Benzeggagh-Kenane mixing), d0n = N / K and d0s = S / K the onset
    openings: max(d_old, d(dn, ds)), irreversible, in [0, 1]."""
    if dn > 0.0:
        dm2 = dn * dn + ds * ds
        dm = math.sqrt(dm2)
        den = dn * dn * d0s * d0s + ds * ds * d0n * d0n
        sq = math.sqrt(dm2 / den)
        d0m = d0n * d0s * sq
        dfm = d0m  # not read below the onset
        if dm > d0m:
            # B^eta (a transcendental call) only past the onset, where delta_fm is read. K delta_0m is
            # written (d0n d0s K) sq: the grouping the fast-math build gave K * d0m when both stood
            # in one block, so the round-off stays bit for bit
            bb = ds * ds / dm2
            dfm = 2.0 / (d0n * d0s * K * sq) * (GIc + (GIIc - GIc) * bb ** eta)
    else:
        dm = abs(ds)
        d0m = d0s
        dfm = 2.0 * GIIc / (K * d0s)
    if dfm <= d0m:
        dfm = d0m * (1.0 + 1e-9)
    if dm > d0m:
        dnew = dfm * (dm - d0m) / (dm * (dfm - d0m))
        if dnew > 1.0:
            dnew = 1.0
        if dnew > d_old:
            return dnew
    return d_old


@numba.njit(cache=True, inline="always")
def add_free_energy(e, dn, ds, d, K, tn):
    """e plus the free energy per unit weight of one integration point at the opening (dn, ds) with
    damage d: psi = (1/2)(1 - d) K (<dn>^2 + ds^2) + (1/2) K <-dn>^2 (Camanho & Davila 2002, sec. 3); a
    fully damaged point holds (1/2) t_n dn while it still resists closing (dn < 0, t_n its traction),
    else nothing. The terms are added to e one by one in this order (the elements sum their points
    through it)."""
    if d >= 1.0:
        if dn < 0.0:
            e += 0.5 * tn * dn
        return e
    e += 0.5 * (1.0 - d) * K * ds * ds
    if dn > 0.0:
        e += 0.5 * (1.0 - d) * K * dn * dn
    else:
        e += 0.5 * K * dn * dn
    return e


@numba.njit(cache=True, inline="always")
def turned_apart(dn, ds, d, K, w):
    """The energy dissipated when an intact point of weight w debonds because the element's faces have turned
    against each other by 90 degrees or more (:func:`solver.fem.cohesive.cohesive_update`,
    :func:`solver.fem3d.cohesive3d.cohesive3d_update`): all of its free energy at the opening (dn, ds),
    w [(1/2)(1 - d) K (<dn>^2 + ds^2) + (1/2) K <-dn>^2], since its tractions stop at once. Our rule: the
    bilinear law (Camanho & Davila 2002) assumes faces that stay parallel, and the frame of a zero-thickness
    element is undefined once they cross."""
    dnp = dn if dn > 0.0 else 0.0
    dnn = dn if dn < 0.0 else 0.0
    return 0.5 * w * K * ((1.0 - d) * (dnp * dnp + ds * ds) + dnn * dnn)
