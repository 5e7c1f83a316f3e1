"""The 3D cubic-spline (M4 B-spline) smoothing kernel and its gradient.

W(r, h) = s (1 - 3/2 q^2 + 3/4 q^3)      for 0 <= q < 1
        = s (1/4) (2 - q)^3              for 1 <= q < 2
        = 0                              for q >= 2,        q = r / h,  s = 1 / (pi h^3)

(Monaghan & Lattanzio 1985; Monaghan 2005, Rep. Prog. Phys. 68:1703, eq. 2.6 with the 3D
normalisation 1 / (pi h^3)): the same kernel as the 2D :mod:`solver.sph.kernel`, normalised so
that its integral over space is 1. Support radius 2h. The gradient is returned as the factor
F = (dW/dr) / r so that grad_i W_ij = F * (r_i - r_j).
"""

from __future__ import annotations

import math

import numba

from ..sph.kernel import spline, spline_factor

SUPPORT = 2.0  # kernel support radius in units of h


@numba.njit(cache=True, inline="always")
def w_cubic3(r, h):
    """Cubic-spline kernel value W(r, h) in 3D (normalisation 1 / (pi h^3); Monaghan 2005 eq. 2.6), the 2D
    kernel's :func:`solver.sph.kernel.spline` with the 3D normalisation."""
    return spline(r / h, 1.0 / (math.pi * h * h * h))


@numba.njit(cache=True, inline="always")
def gradw_factor3(r, h):
    """F = (dW/dr)/r of the 3D cubic spline (normalisation 1 / (pi h^3); Monaghan 2005 eq. 2.6), so
    grad_i W_ij = F (r_i - r_j); F <= 0 (:func:`solver.sph.kernel.spline_factor`)."""
    return spline_factor(r / h, 1.0 / (math.pi * h * h * h), h, r)


@numba.njit(cache=True, inline="always")
def w_and_factor3(r, h):
    """(W(r, h), F(r, h)) of the 3D cubic spline together, without branches: the M4 B-spline in
    truncated powers, W = s [(2 - q)_+^3 / 4 - (1 - q)_+^3] (Schoenberg 1946; Monaghan 2005 eq. 2.6
    rewritten), F = (dW/dr) / r = s [3 (1 - q)_+^2 - 3/4 (2 - q)_+^2] / (h r); inside q < 1 the factor
    is taken in the cancelled form s (-3 + 9/4 q) / h^2 (finite at r = 0). ``r`` must be < 2h."""
    q = r / h
    s = 1.0 / (math.pi * h * h * h)
    t2 = max(2.0 - q, 0.0)
    t1 = max(1.0 - q, 0.0)
    w = s * (0.25 * t2 * t2 * t2 - t1 * t1 * t1)
    inner = s * (-3.0 + 2.25 * q) / (h * h)
    outer = -0.75 * s * t2 * t2 / (h * r)
    return w, (inner if q < 1.0 else outer)
