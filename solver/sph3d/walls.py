"""Frictionless rigid walls of the 3D particles: penalty planes.

A wall is a plane through the point p with the unit normal n pointing to the side the particles
belong to (the strip's lateral symmetry planes z = 0 and z = W, a floor). A particle at x with gap
g = (x - p) . n < 0 has penetrated by -g and is pushed back along n with the penalty

    f = -k m g n          (k [1/s^2] per unit mass: the 2D particles' by-mass penalty of
                           :func:`solver.contact.tool_contact`, k m_i; LS-DYNA's soft constraint)

and no tangential force (a frictionless plane: a symmetry plane conserves the tangential
momentum). The penalty energy 1/2 k m g^2 is stored elastically; the kicks of
:mod:`solver.sph3d.loop` book the walls' work on the particles exactly as the 2D loop books the
tool's, so the energy balance closes to the integration error. Every particle's penalty oscillator
has the same period 2 pi / sqrt(k): the step is held to at most :data:`WALL_OMEGA_DT` / sqrt(k)
(:func:`solver.sph3d.loop.stable_dt`, as the 2D loop's CONTACT_OMEGA_DT).
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: the largest omega dt of a particle's wall penalty oscillator
WALL_OMEGA_DT = 1.0


def plane(point, normal, k_per_mass: float) -> np.ndarray:
    """One wall row: point (3), unit normal (3, towards the particles' side), k [1/s^2]."""
    nrm = np.asarray(normal, np.float64)
    ln = float(np.linalg.norm(nrm))
    if not (ln > 0 and math.isfinite(ln)):
        raise ValueError(f"normal = {normal!r}: must be a non-zero finite vector")
    if not (k_per_mass > 0 and math.isfinite(k_per_mass)):
        raise ValueError(f"k_per_mass = {k_per_mass!r}: must be finite and > 0 (1/s^2)")
    return np.concatenate([np.asarray(point, np.float64), nrm / ln, [float(k_per_mass)]])


def strip_walls(width: float, k_per_mass: float, floor_y: float | None = None) -> np.ndarray:
    """The strip's lateral symmetry planes z = 0 (normal +z) and z = width (normal -z), and a floor
    y = floor_y (normal +y) when given: (n_w, 7)."""
    rows = [plane((0, 0, 0), (0, 0, 1), k_per_mass), plane((0, 0, width), (0, 0, -1), k_per_mass)]
    if floor_y is not None:
        rows.append(plane((0, floor_y, 0), (0, 1, 0), k_per_mass))
    return np.vstack(rows)


def wall_stiffness_for(dt: float, omega_dt: float = 0.5) -> float:
    """A wall stiffness per unit mass whose penalty oscillator has omega dt = ``omega_dt`` at step dt."""
    return (omega_dt / dt) ** 2


@numba.njit(cache=True, inline="always")
def wall_accel(x0, x1, x2, walls):
    """The acceleration -k g n summed over the walls a particle at (x0, x1, x2) penetrates (g < 0)."""
    ax = 0.0
    ay = 0.0
    az = 0.0
    for w in range(walls.shape[0]):
        g = (x0 - walls[w, 0]) * walls[w, 3] + (x1 - walls[w, 1]) * walls[w, 4] + (x2 - walls[w, 2]) * walls[w, 5]
        if g < 0.0:
            s = -walls[w, 6] * g
            ax += s * walls[w, 3]
            ay += s * walls[w, 4]
            az += s * walls[w, 5]
    return ax, ay, az


@numba.njit(cache=True)
def penalty_energy(x, m, walls):
    """Elastic energy stored in the walls' penalties, sum 1/2 k m g^2 over penetrating particles [J]."""
    e = 0.0
    for i in range(x.shape[1]):
        for w in range(walls.shape[0]):
            g = ((x[0, i] - walls[w, 0]) * walls[w, 3] + (x[1, i] - walls[w, 1]) * walls[w, 4]
                 + (x[2, i] - walls[w, 2]) * walls[w, 5])
            if g < 0.0:
                e += 0.5 * walls[w, 6] * m[i] * g * g
    return e
