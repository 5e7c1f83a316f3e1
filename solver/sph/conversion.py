"""FEM-to-SPH conversion: dormant particles slaved to their elements, activated when the element fails.

Anchor: OpenRadioss Sol2SPH (particles pre-seeded in the elements, the element's mass, velocity,
stress moved to them on failure) and the paper's hybrid (docs/model.md, "The scene"). Per converting
element e with nodes a = 1..4 (counter-clockwise), element mass m_e (lumped a quarter to each node):

* position   x_p = (1/4) sum_a x_a                            (element centre)
* mass       m_p = m_e;  node masses m_a -= m_e / 4           (total mass unchanged to round-off)
* velocity   v_p = (1/4) sum_a v_a = sum_a (m_e/4) v_a / m_e   (momentum conserved to round-off)
* density    rho_p = m_e / A_e(current)                        (particle volume = element area)
             (an element crushed below CRUSHED_J of its reference area, or with a non-finite
             stress, converts to powder: no stress, D = 1, rho = m_e / (CRUSHED_J A_e0))
* stress     sigma_p = sigma_e; material axis theta_p = theta_e(initial) + rotation of the element,
             the polar-decomposition angle of the centre deformation gradient
             F = (dx/dxi)(dX/dxi)^-1, angle = atan2(F21 - F12, F11 + F22)
* energy     kinetic-energy jump dKE = 1/2 m_e |v_p|^2 - sum_a 1/2 (m_e/4) |v_a|^2 <= 0 (Jensen);
             its magnitude is booked as ``conversion`` loss in the energy balance.

A dormant particle carries no load and is not in the neighbour search; :func:`slave_dormant` puts it
at its element's centre (for output). The stiffness after activation is the parent material's times
(1 - D0) (material table, :mod:`solver.sph.materials`); damage then keeps growing to full fracture
(:mod:`solver.sph.solid`). Only materials listed as converting get particles: a scene without
conversion allocates none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from . import materials as mt
from . import particles as pp
from .particles import ACTIVE, DMG, ESXX, ESXY, ESYY, KAPPA, M, RHO, SXX, SXY, SYY, THETA, VX, VY, X, Y

#: an element whose area fell below this fraction of its reference area converts to powder
CRUSHED_J = 0.5


@numba.njit(cache=True)
def element_rotation(X0, Y0, xc, yc):
    """Rotation angle of a bilinear quad at its centre: polar decomposition of F = J J0^-1
    (dN/dxi = (-1, 1, 1, -1)/4, dN/deta = (-1, -1, 1, 1)/4 at xi = eta = 0)."""
    dxi = (-0.25, 0.25, 0.25, -0.25)
    det_ = (-0.25, -0.25, 0.25, 0.25)
    J0 = np.zeros((2, 2))
    J = np.zeros((2, 2))
    for a in range(4):
        J0[0, 0] += X0[a] * dxi[a]
        J0[0, 1] += X0[a] * det_[a]
        J0[1, 0] += Y0[a] * dxi[a]
        J0[1, 1] += Y0[a] * det_[a]
        J[0, 0] += xc[a] * dxi[a]
        J[0, 1] += xc[a] * det_[a]
        J[1, 0] += yc[a] * dxi[a]
        J[1, 1] += yc[a] * det_[a]
    d0 = J0[0, 0] * J0[1, 1] - J0[0, 1] * J0[1, 0]
    i00 = J0[1, 1] / d0
    i01 = -J0[0, 1] / d0
    i10 = -J0[1, 0] / d0
    i11 = J0[0, 0] / d0
    f11 = J[0, 0] * i00 + J[0, 1] * i10
    f12 = J[0, 0] * i01 + J[0, 1] * i11
    f21 = J[1, 0] * i00 + J[1, 1] * i10
    f22 = J[1, 0] * i01 + J[1, 1] * i11
    return math.atan2(f21 - f12, f11 + f22)


@numba.njit(cache=True)
def convert_failed(elem_alive, elem_particle, quads, X0, Y0, x, y, vx, vy, node_mass, elem_mass,
                   esxx, esyy, esxy, elem_theta, F, I, act, n_act, out):
    """Activate the particle of every dead element (``elem_alive[e] == 0``) whose particle is still
    dormant; equations in the module docstring. Node masses that fall to round-off level (all
    elements of the node gone) are set to exactly 0.

    Returns the new number of active particles (their indices appended to ``act``);
    out[0] += kinetic energy lost (>= 0), out[1] += number converted, out[2] += kinetic energy the
    nodes gave up with the mass (= particles' kinetic energy + loss)."""
    n_e = elem_alive.shape[0]
    for e in range(n_e):
        if elem_alive[e] != 0:
            continue
        p = elem_particle[e]
        if p < 0 or I[ACTIVE, p] != 0:
            continue
        me = elem_mass[e]
        q = me * 0.25
        sx = 0.0
        sy = 0.0
        svx = 0.0
        svy = 0.0
        ke_nodes = 0.0
        xa = np.empty(4)
        ya = np.empty(4)
        Xa = np.empty(4)
        Ya = np.empty(4)
        for a in range(4):
            nd = quads[e, a]
            xa[a] = x[nd]
            ya[a] = y[nd]
            Xa[a] = X0[nd]
            Ya[a] = Y0[nd]
            sx += x[nd]
            sy += y[nd]
            svx += vx[nd]
            svy += vy[nd]
            ke_nodes += 0.5 * q * (vx[nd] * vx[nd] + vy[nd] * vy[nd])
            m_new = node_mass[nd] - q
            if m_new <= 1e-12 * q:
                m_new = 0.0
            node_mass[nd] = m_new
        # current area (shoelace, counter-clockwise positive)
        area = 0.5 * ((xa[0] * ya[1] - xa[1] * ya[0]) + (xa[1] * ya[2] - xa[2] * ya[1])
                      + (xa[2] * ya[3] - xa[3] * ya[2]) + (xa[3] * ya[0] - xa[0] * ya[3]))
        pvx = 0.25 * svx
        pvy = 0.25 * svy
        F[X, p] = 0.25 * sx
        F[Y, p] = 0.25 * sy
        F[VX, p] = pvx
        F[VY, p] = pvy
        F[M, p] = me
        area0 = 0.5 * ((Xa[0] * Ya[1] - Xa[1] * Ya[0]) + (Xa[1] * Ya[2] - Xa[2] * Ya[1])
                       + (Xa[2] * Ya[3] - Xa[3] * Ya[2]) + (Xa[3] * Ya[0] - Xa[0] * Ya[3]))
        sig_ok = math.isfinite(esxx[e]) and math.isfinite(esyy[e]) and math.isfinite(esxy[e])
        if area >= CRUSHED_J * area0 and sig_ok:
            F[RHO, p] = me / area
            s_xx, s_yy, s_xy, dmg = esxx[e], esyy[e], esxy[e], 0.0
        else:
            # a crushed or inverted element (eroded by the engine): its deformation gradient means
            # nothing any more; the particle starts as powder (fully fractured, no stress) at the
            # density of half the element's reference area
            F[RHO, p] = me / (CRUSHED_J * abs(area0))
            s_xx, s_yy, s_xy, dmg = 0.0, 0.0, 0.0, 1.0
        F[SXX, p] = s_xx
        F[SYY, p] = s_yy
        F[SXY, p] = s_xy
        F[ESXX, p] = s_xx
        F[ESYY, p] = s_yy
        F[ESXY, p] = s_xy
        F[THETA, p] = elem_theta[e] + element_rotation(Xa, Ya, xa, ya)
        F[DMG, p] = dmg
        F[KAPPA, p] = 0.0
        I[ACTIVE, p] = 1
        elem_particle[e] = -1  # converted once: a particle taken out later (escaped) is not converted again
        act[n_act] = p
        n_act += 1
        out[0] += ke_nodes - 0.5 * me * (pvx * pvx + pvy * pvy)
        out[1] += 1.0
        out[2] += ke_nodes
    return n_act


@numba.njit(cache=True)
def slave_dormant(elem_alive, elem_particle, quads, x, y, vx, vy, F, I):
    """Put every dormant particle of a living element at its element's centre with its centre velocity."""
    for e in range(elem_alive.shape[0]):
        p = elem_particle[e]
        if p < 0 or I[ACTIVE, p] != 0:
            continue
        sx = 0.0
        sy = 0.0
        svx = 0.0
        svy = 0.0
        for a in range(4):
            nd = quads[e, a]
            sx += x[nd]
            sy += y[nd]
            svx += vx[nd]
            svy += vy[nd]
        F[X, p] = 0.25 * sx
        F[Y, p] = 0.25 * sy
        F[VX, p] = 0.25 * svx
        F[VY, p] = 0.25 * svy


@dataclass
class Conversion:
    """Dormant particles of the converting elements. ``elem_particle[e]`` is the dormant particle of
    element e (-1 if its material does not convert or once it has converted); ``particle_elem[p]`` the
    element of particle p."""

    particles: pp.Particles
    elem_particle: np.ndarray  # int64 (n_elems,)
    particle_elem: np.ndarray  # int64 (n_particles,)
    n_converted: int = 0
    ke_from_nodes: float = 0.0  # kinetic energy taken off the nodes with the mass [J/m]

    def convert(self, elem_alive, quads, X0, Y0, x, y, vx, vy, node_mass, elem_mass, sxx, syy, sxy,
                elem_theta) -> int:
        """Convert the dead elements' dormant particles (see :func:`convert_failed`); returns how many."""
        P = self.particles
        out = np.zeros(3)
        P.n_act = int(convert_failed(elem_alive, self.elem_particle, quads, X0, Y0, x, y, vx, vy, node_mass,
                                     elem_mass, sxx, syy, sxy, elem_theta, P.F, P.I, P.act, P.n_act, out))
        n = int(out[1])
        if n:
            P.e_conversion += float(out[0])
            self.ke_from_nodes += float(out[2])
            P.forces_valid = False
            self.n_converted += n
        return n


def build_dormant(material: np.ndarray, converts: np.ndarray, mats: np.ndarray, prm: np.ndarray) -> Conversion | None:
    """One dormant particle per element whose material id m has ``converts[m]``; the particle's SPH
    material row is m (``mats`` indexed by the mesh material id). Returns None when no element converts
    (nothing is allocated)."""
    material = np.asarray(material)
    conv = np.asarray(converts, bool)[material]
    n = int(conv.sum())
    if n == 0:
        return None
    P = pp.allocate(n, mats, prm)
    elem_particle = np.full(material.size, -1, np.int64)
    elem_particle[conv] = np.arange(n)
    particle_elem = np.flatnonzero(conv).astype(np.int64)
    P.I[pp.MAT] = material[conv]
    P.F[pp.CS] = np.sqrt(mats[P.I[pp.MAT], mt.M_CMAX] * (1 - mats[P.I[pp.MAT], mt.M_D0]) / mats[P.I[pp.MAT], mt.M_RHO0])
    return Conversion(P, elem_particle, particle_elem)


def scene_materials(si, mass_scaling: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The SPH material table for a scene, indexed by mesh material id (FIBRE=0, MATRIX=1, EHM=2),
    and which of them convert. Fibre: transversely isotropic, D0 = physics.sph_damage_fibre; matrix:
    isotropic, D0 = physics.sph_damage_matrix; fracture strain kappa_f = the parent's failure strain
    (Xt/E1 for the fibre, sigma_u/E for the matrix). EHM elements are deleted without conversion
    (the paper's particles come from the micro zone); its row is a placeholder copy of the matrix."""
    p = si.physics
    fi, ma = si.fibre, si.matrix
    fibre = mt.transversely_isotropic(fi.E1, fi.E2, fi.G12, fi.nu12, fi.nu23, fi.rho * mass_scaling,
                                      D0=p.sph_damage_fibre, kappa_f=fi.Xt / fi.E1)
    matrix = mt.isotropic(ma.E, ma.nu, ma.rho * mass_scaling, D0=p.sph_damage_matrix, kappa_f=ma.sigma_u / ma.E)
    return mt.table(fibre, matrix, matrix.copy()), np.array([True, True, False])
