"""Boundary particles of solid SPH: the mirror (ghost) clamp.

A clamp face u = 0 on a straight wall x = x_w is represented by ghost particles behind it. Ghost g
is the reflection of a body particle p_1 (its partner at the mirror distance d) through the point
c_g = (x_w, Y_p1) on the face, with the opposite velocity:

    x_g = 2 c_g - x_p1,        v_g = -v_p1,

i.e. the displacement continued oddly through the face, u(x_w - d) = -u(x_w + d), so that u = 0 and
v = 0 hold on the face to second order in the spacing, and the particles next to the face have a
complete kernel support (no free surface at the clamp). This is the reflected ghost of Libersky,
Petschek, Carney, Hipp & Allahdadi (1993, JCP 109:67, sec. 4) and Randles & Libersky (1996, CMAME
139:375, sec. 5), with the antisymmetric (no-slip) ghost velocity of Morris, Fox & Zhu (1997, JCP
136:214, sec. 3.1) applied to both components (a clamp, not a slip wall).

The ghosts' stress is not their own: it is the body's stress continued through the face
(:func:`mirror_stress`; even, sigma(x_w - d) = sigma(x_w + d), or linear, 2 sigma(d) - sigma(3d)).
Ghosts that kept the stress of their own (odd) motion flip the Poisson strain e_yy (u_y is odd in x),
so next to the clamp their free surfaces carry a spurious sigma_yy = 2 C12 e_xx; on the oscillating
plate that pumped an odd-even lattice mode at the face (the wall did work: +18 % energy in T/5 at
V_f = 0.001, eps = 0, n = 8), while the continued stress keeps the energy to 0.3 % over T/5.
At Gray et al.'s amplitude the mirror clamp is not robust beyond n = 10 (the case ``sph-plate``, scripts/sph_plate_table.py).
The ghosts are held FIXED; their accelerations are computed but not used.

Only scenes that use a mirror clamp carry its arrays (:meth:`solver.sph.particles.Particles.set_mirror`);
all others pass the empty :data:`NO_MIRROR`.
"""

from __future__ import annotations

import numba
import numpy as np

from .particles import CS, ESXX, ESXY, ESYY, RHO, RXX, RXY, RYY, SXX, SXY, SYY, VX, VY, X, Y

#: the (index, coefficient) arrays of a scene without a mirror clamp
NO_MIRROR = (np.zeros((3, 0), np.int64), np.zeros((4, 0)))


@numba.njit(cache=True)
def mirror_ghosts(F, idx, coef):
    """Place the ghosts: x_g = 2 c_g - x_p1, v_g = -v_p1 (reflection of the partner through the point
    c_g of the face; Libersky et al. 1993 JCP 109:67 sec. 4 reflected ghosts, with the antisymmetric
    wall velocity of Morris, Fox & Zhu 1997 JCP 136:214 sec. 3.1 in both components: a clamp).
    idx[0, g] ghost, idx[1, g] partner; coef[0, g], coef[1, g] the point c_g."""
    for g in range(idx.shape[1]):
        i = idx[0, g]
        p = idx[1, g]
        F[X, i] = 2.0 * coef[0, g] - F[X, p]
        F[Y, i] = 2.0 * coef[1, g] - F[Y, p]
        F[VX, i] = -F[VX, p]
        F[VY, i] = -F[VY, p]


@numba.njit(cache=True)
def mirror_stress(F, idx, coef):
    """The ghosts' stress continued from the body through the face: f_g = b_1 f_p1 + b_2 f_p2 for the
    state, acting and artificial stress, the density and the sound speed (coef rows 2, 3 = b_1, b_2;
    partners p1 at the mirror distance d, p2 at 3d): b = (1, 0) the even continuation
    sigma(x_w - d) = sigma(x_w + d), b = (2, -1) the linear extrapolation 2 sigma(d) - sigma(3d).
    (Libersky et al. 1993 JCP 109:67 sec. 4 and Randles & Libersky 1996 CMAME 139:375 sec. 5 give
    their ghosts the stress of the mirrored particle.)"""
    for g in range(idx.shape[1]):
        i = idx[0, g]
        p = idx[1, g]
        q = idx[2, g]
        b1 = coef[2, g]
        b2 = coef[3, g]
        for r in (SXX, SYY, SXY, ESXX, ESYY, ESXY, RXX, RYY, RXY, RHO, CS):
            F[r, i] = b1 * F[r, p] + b2 * F[r, q]


def mirror_pairs(x, y, wall_x, tol, stress="even"):
    """Mirror clamp of a lattice body on the face x = wall_x: every particle with x < wall_x becomes
    a ghost of the particle at its mirror position (2 wall_x - x, y) (within ``tol``); ``stress``
    "even" (sigma_g = sigma_p1) or "linear" (sigma_g = 2 sigma_p1 - sigma_p2, p2 at three times the
    ghost's depth). Raises where a partner is missing. Returns (idx int64[3, n_g], coef float64[4, n_g],
    ghost mask) for :meth:`solver.sph.particles.Particles.set_mirror`."""
    from scipy.spatial import cKDTree

    if stress not in ("even", "linear"):
        raise ValueError(f"stress = {stress!r}: allowed 'even', 'linear'")
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    tree = cKDTree(np.c_[x, y])
    g = np.flatnonzero(x < wall_x)
    d = wall_x - x[g]
    d1, p1 = tree.query(np.c_[wall_x + d, y[g]])
    if stress == "linear":
        d2, p2 = tree.query(np.c_[wall_x + 3 * d, y[g]])
        b1, b2 = 2.0, -1.0
    else:
        d2, p2, b1, b2 = d1, p1, 1.0, 0.0
    ok = (d1 < tol) & (d2 < tol)
    if not ok.all():
        raise ValueError(f"{int((~ok).sum())} particles behind the wall x = {wall_x} have no mirror partner")
    idx = np.vstack([g, p1, p2]).astype(np.int64)
    coef = np.vstack([np.full(g.size, float(wall_x)), 0.5 * (y[g] + y[p1]), np.full(g.size, b1), np.full(g.size, b2)])
    mask = np.zeros(x.size, bool)
    mask[g] = True
    return idx, coef, mask
