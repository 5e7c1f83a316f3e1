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

SUPPORT = 2.0  # kernel support radius in units of h


@numba.njit(cache=True, inline="always")
def w_cubic3(r, h):
    """Cubic-spline kernel value W(r, h) in 3D (normalisation 1 / (pi h^3); Monaghan 2005 eq. 2.6)."""
    q = r / h
    s = 1.0 / (math.pi * h * h * h)
    if q < 1.0:
        return s * (1.0 - 1.5 * q * q + 0.75 * q * q * q)
    if q < 2.0:
        t = 2.0 - q
        return s * 0.25 * t * t * t
    return 0.0


@numba.njit(cache=True, inline="always")
def gradw_factor3(r, h):
    """F = (dW/dr)/r of the 3D cubic spline, so grad_i W_ij = F (r_i - r_j); F <= 0.

    dW/dq = s (-3 q + 9/4 q^2) for q < 1, -3/4 s (2 - q)^2 for 1 <= q < 2 (Monaghan 2005 eq. 2.6),
    s = 1 / (pi h^3). At r -> 0 the factor tends to -3 s / h^2 (finite).
    """
    q = r / h
    s = 1.0 / (math.pi * h * h * h)
    if q < 1.0:
        return s * (-3.0 + 2.25 * q) / (h * h)
    if q < 2.0:
        t = 2.0 - q
        return -0.75 * s * t * t / (h * r)
    return 0.0
