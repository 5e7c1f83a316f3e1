"""Symmetric 3x3 tensors in closed form, shared by the 3D engines' laws (:mod:`solver.fem3d.laws3d`) and the 3D
particles (:mod:`solver.sph3d.solid`)."""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always")
def sym_eig3(a00, a11, a22, a01, a12, a02):
    """Eigenvalues e1 >= e2 >= e3 of a symmetric 3x3 matrix, in closed form (Smith 1961, CACM 4:168:
    the trigonometric solution of the characteristic cubic)."""
    p1 = a01 * a01 + a12 * a12 + a02 * a02
    q = (a00 + a11 + a22) / 3.0
    b00 = a00 - q
    b11 = a11 - q
    b22 = a22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    if p2 <= 1e-300:  # isotropic to round-off
        return q, q, q
    p = math.sqrt(p2 / 6.0)
    ip = 1.0 / p
    c00 = b00 * ip
    c11 = b11 * ip
    c22 = b22 * ip
    c01 = a01 * ip
    c12 = a12 * ip
    c02 = a02 * ip
    r = 0.5 * (c00 * (c11 * c22 - c12 * c12) - c01 * (c01 * c22 - c12 * c02) + c02 * (c01 * c12 - c11 * c02))
    if r <= -1.0:
        phi = math.pi / 3.0
    elif r >= 1.0:
        phi = 0.0
    else:
        phi = math.acos(r) / 3.0
    e1 = q + 2.0 * p * math.cos(phi)
    e3 = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    e2 = 3.0 * q - e1 - e3
    return e1, e2, e3
