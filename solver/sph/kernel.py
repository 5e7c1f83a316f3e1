"""The 2D cubic-spline (M4 B-spline) smoothing kernel and its gradient.

W(r, h) = s (1 - 3/2 q^2 + 3/4 q^3)      for 0 <= q < 1
        = s (1/4) (2 - q)^3              for 1 <= q < 2
        = 0                              for q >= 2,        q = r / h,  s = 10 / (7 pi h^2)

(Monaghan & Lattanzio 1985; Monaghan 2005, Rep. Prog. Phys. 68:1703, eq. 2.6; the kernel of
Gray, Monaghan & Swift 2001, CMAME 190:6641). Support radius 2h. The gradient is returned as
the factor F = (dW/dr) / r so that grad_i W_ij = F * (r_i - r_j).
"""

from __future__ import annotations

import math

import numba

SUPPORT = 2.0  # kernel support radius in units of h


@numba.njit(cache=True, inline="always")
def spline(q, s):
    """The cubic spline W = s w(q) of any dimension, q = r / h, s its normalisation: w = 1 - 3/2 q^2 + 3/4 q^3
    (q < 1), (2 - q)^3 / 4 (1 <= q < 2), 0 beyond (Monaghan & Lattanzio 1985; Monaghan 2005 eq. 2.6)."""
    if q < 1.0:
        return s * (1.0 - 1.5 * q * q + 0.75 * q * q * q)
    if q < 2.0:
        t = 2.0 - q
        return s * 0.25 * t * t * t
    return 0.0


@numba.njit(cache=True, inline="always")
def spline_factor(q, s, h, r):
    """F = (dW/dr) / r of :func:`spline` (any dimension, normalisation s, q = r / h); F <= 0.

    dW/dq = s (-3 q + 9/4 q^2) for q < 1, -3/4 s (2 - q)^2 for 1 <= q < 2 (Monaghan 2005 eq. 2.6).
    At r -> 0 the factor tends to -3 s / h^2 (finite).
    """
    if q < 1.0:
        # (-3 q + 2.25 q^2) / (h r) = (-3 + 2.25 q) / h^2
        return s * (-3.0 + 2.25 * q) / (h * h)
    if q < 2.0:
        t = 2.0 - q
        return -0.75 * s * t * t / (h * r)
    return 0.0


@numba.njit(cache=True, inline="always")
def w_cubic(r, h):
    """Cubic-spline kernel value W(r, h) in 2D (normalisation 10 / (7 pi h^2); Monaghan 2005 eq. 2.6)."""
    return spline(r / h, 10.0 / (7.0 * math.pi * h * h))


@numba.njit(cache=True, inline="always")
def gradw_factor(r, h):
    """F = (dW/dr)/r of the 2D cubic spline (normalisation 10 / (7 pi h^2); Monaghan 2005 eq. 2.6), so
    grad_i W_ij = F (r_i - r_j); F <= 0 (:func:`spline_factor`)."""
    return spline_factor(r / h, 10.0 / (7.0 * math.pi * h * h), h, r)
