"""Particle materials: one row per material in a float64 table (no Python objects in kernels).

Stiffness is stored in the material frame (axis 1 = fibre direction at angle theta from x, axis 2
in plane across it, axis 3 out of plane) as the plane-strain reduced coefficients
sigma'_11 = C11 e'_11 + C12 e'_22, sigma'_22 = C12 e'_11 + C22 e'_22, sigma'_12 = 2 C66 e'_12.

* isotropic (matrix, EHM approximation, verification solids): C11 = C22 = lambda + 2G, C12 = lambda,
  C66 = G (plane strain);
* transversely isotropic fibre (axis 1 the symmetry axis): the 3x3 normal block of the 3D compliance
  S = [[1/E1, -nu12/E1, -nu12/E1], [-nu12/E1, 1/E2, -nu23/E2], [-nu12/E1, -nu23/E2, 1/E2]]
  is inverted and its in-plane block (1, 2) kept (plane strain e33 = 0), C66 = G12
  (Jones, Mechanics of Composite Materials, ch. 2).

Columns: see the ``M_*`` constants. ``D0`` is the damage a converted particle starts with
(stiffness x (1 - D0)); ``KAPPA_F`` the tensile principal strain a particle accumulates after
activation until it is fully fractured (``inf``: no damage growth, as in the verification solids).
``CMAX`` is the largest directional plane-strain P-wave modulus over all in-plane directions (the
signal speed of the stiffest direction).
"""

from __future__ import annotations

import math

import numpy as np

M_C11, M_C12, M_C22, M_C66, M_RHO0, M_D0, M_KAPPA_F, M_CMAX = range(8)
N_MAT_COLS = 8


def _row(C11, C12, C22, C66, rho, D0, kappa_f):
    if not (rho > 0):
        raise ValueError(f"density = {rho!r}: must be > 0 kg/m3")
    if not (0.0 <= D0 < 1.0):
        raise ValueError(f"damage D0 = {D0!r}: allowed 0 <= D0 < 1")
    if not (kappa_f > 0):
        raise ValueError(f"fracture strain kappa_f = {kappa_f!r}: must be > 0 (inf = no damage growth)")
    phi = np.linspace(0.0, math.pi, 181)
    c, s = np.cos(phi), np.sin(phi)
    q11 = c**4 * C11 + 2 * c**2 * s**2 * (C12 + 2 * C66) + s**4 * C22  # rotated P-wave modulus
    cmax = float(max(q11.max(), C11, C22))
    if not (C11 > 0 and C22 > 0 and C66 > 0 and C11 * C22 - C12 * C12 > 0):
        raise ValueError(f"stiffness C11={C11:g}, C12={C12:g}, C22={C22:g}, C66={C66:g}: not positive definite")
    return np.array([C11, C12, C22, C66, rho, D0, kappa_f, cmax], np.float64)


def isotropic(E: float, nu: float, rho: float, D0: float = 0.0, kappa_f: float = math.inf) -> np.ndarray:
    """Row of an isotropic plane-strain material (E [Pa], nu, rho [kg/m3])."""
    if not (E > 0):
        raise ValueError(f"E = {E!r}: must be > 0 Pa")
    if not (-1.0 < nu < 0.5):
        raise ValueError(f"nu = {nu!r}: allowed -1 < nu < 0.5")
    G = E / (2.0 * (1.0 + nu))
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    return _row(lam + 2 * G, lam, lam + 2 * G, G, rho, D0, kappa_f)


def transversely_isotropic(E1: float, E2: float, G12: float, nu12: float, nu23: float, rho: float,
                           D0: float = 0.0, kappa_f: float = math.inf) -> np.ndarray:
    """Row of a transversely isotropic fibre (axis 1 along the fibre), plane strain in the 1-2 plane."""
    S = np.array([[1 / E1, -nu12 / E1, -nu12 / E1],
                  [-nu12 / E1, 1 / E2, -nu23 / E2],
                  [-nu12 / E1, -nu23 / E2, 1 / E2]])
    C = np.linalg.inv(S)
    return _row(C[0, 0], C[0, 1], C[1, 1], G12, rho, D0, kappa_f)


def table(*rows: np.ndarray) -> np.ndarray:
    """Stack material rows into the (n_mat, N_MAT_COLS) table the kernels read."""
    return np.ascontiguousarray(np.vstack(rows).astype(np.float64))


def wave_speed(mats: np.ndarray, m: int) -> float:
    """Largest undamaged-parent plane-strain wave speed sqrt(CMAX (1 - D0) / rho0) of material ``m``."""
    return math.sqrt(mats[m, M_CMAX] * (1.0 - mats[m, M_D0]) / mats[m, M_RHO0])
