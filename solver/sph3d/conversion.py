"""Hexahedron-to-particle conversion: a failed element of the 3D engine becomes one SPH particle.

The 3D form of :mod:`solver.sph.conversion` (OpenRadioss Sol2SPH; the paper's hybrid, docs/model.md
"The scene"), reading the 3D engine's state (:class:`solver.fem3d.loop.Hex8State`: ``x``, ``v``,
``mass``, ``meff``, ``cmass``, ``hexes``, ``mat``, ``rho``, ``vol0``, ``b0``, ``pk2``, ``tie_s``, ``tie_m``).
Per converting element e with nodes a = 1..8, element mass m_e = rho_e V0_e (lumped an eighth to
each node):

* position   x_p = (1/8) sum_a x_a                             (element centre)
* mass       m_p = m_e;  node masses m_a -= m_e / 8            (total mass unchanged to round-off;
             a tied node's share is taken off its master's effective mass ``meff`` too, since the
             master carries the group's mass); the mass the rigid body's penalty acts on (``cmass``,
             :mod:`solver.fem3d.contact3d`: k m_a per node, k per unit mass) falls with it, so that
             a node that gave up mass keeps omega dt = sqrt(k) dt on the tool's spring instead of
             sqrt(k m_old / m_new) dt (past 2, the central difference diverges, at m_new < m_old / 4)
* velocity   v_p = (1/8) sum_a v_a = sum_a (m_e/8) v_a / m_e   (momentum conserved to round-off)
* density    rho_p = m_e / (J V0), J = det F, F = sum_a x_a (x) b0_a the element's mean deformation
             gradient (:mod:`solver.fem3d.hex8`); an element crushed below CRUSHED_J (J < 1/2), or
             with a non-finite stress, converts stress-free at rho_p = m_e / (CRUSHED_J V0) (as 2D)
* stress     sigma_p = F S F^T / J, the element's Cauchy stress from its 2nd Piola-Kirchhoff S
             (the engine's ``pk2``; the particle's Jaumann update continues from it)
* energy     kinetic-energy jump sum_a 1/2 (m_e/8) |v_a|^2 - 1/2 m_e |v_p|^2 >= 0 (Jensen), booked
             as the conversion loss.

The engine's velocities are those of its last half step (v^{n+1/2}); the particle takes them, so
the momentum of nodes + particles is what the nodes had. Removing the element from the engine's
force loop is the engine's part (this module writes only the nodal masses). Material: the
particle's SPH row is ``sph_mat[mat_e]`` (an isotropic row of :mod:`solver.sph.materials`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from . import particles as pp

#: an element whose volume fell below this fraction of its reference volume converts stress-free
CRUSHED_J = 0.5


@numba.njit(cache=True)
def convert_hexes(ids, hexes, mat, rho_tab, vol0, b0, x, v, pk2, mass, meff, cmass, master, px, pv, pm, prho, psig,
                  out):
    """Particles of the elements ``ids`` (module docstring) into px, pv (3, k), pm, prho (k), psig (6, k);
    the nodes' masses reduced (``mass``, ``meff`` and the contact mass ``cmass``: at most what the node's
    velocity update divides by, its ``meff``, or its own ``mass`` for a tied node). out[0] += kinetic energy lost (>= 0), out[1] += kinetic energy the nodes
    gave up with the mass, out[2] += number of crushed elements (converted stress-free)."""
    for p in range(ids.shape[0]):
        e = ids[p]
        me = rho_tab[mat[e]] * vol0[e]
        q = 0.125 * me
        sx = 0.0
        sy = 0.0
        sz = 0.0
        svx = 0.0
        svy = 0.0
        svz = 0.0
        ke = 0.0
        f00 = 0.0
        f01 = 0.0
        f02 = 0.0
        f10 = 0.0
        f11 = 0.0
        f12 = 0.0
        f20 = 0.0
        f21 = 0.0
        f22 = 0.0
        for a in range(8):
            nd = hexes[e, a]
            xa = x[0, nd]
            ya = x[1, nd]
            za = x[2, nd]
            sx += xa
            sy += ya
            sz += za
            svx += v[0, nd]
            svy += v[1, nd]
            svz += v[2, nd]
            ke += 0.5 * q * (v[0, nd] * v[0, nd] + v[1, nd] * v[1, nd] + v[2, nd] * v[2, nd])
            bx = b0[e, a]
            by = b0[e, 8 + a]
            bz = b0[e, 16 + a]
            f00 += xa * bx
            f01 += xa * by
            f02 += xa * bz
            f10 += ya * bx
            f11 += ya * by
            f12 += ya * bz
            f20 += za * bx
            f21 += za * by
            f22 += za * bz
            m_new = mass[nd] - q
            if m_new <= 1e-12 * q:
                m_new = 0.0
            mass[nd] = m_new
            ms = master[nd]
            m_eff = meff[ms] - q
            if m_eff <= 1e-12 * q:
                m_eff = 0.0
            meff[ms] = m_eff
            cmass[nd] = min(cmass[nd], m_new if ms != nd else m_eff)
            cmass[ms] = min(cmass[ms], m_eff)
        vx = 0.125 * svx
        vy = 0.125 * svy
        vz = 0.125 * svz
        px[0, p] = 0.125 * sx
        px[1, p] = 0.125 * sy
        px[2, p] = 0.125 * sz
        pv[0, p] = vx
        pv[1, p] = vy
        pv[2, p] = vz
        pm[p] = me
        J = f00 * (f11 * f22 - f12 * f21) - f01 * (f10 * f22 - f12 * f20) + f02 * (f10 * f21 - f11 * f20)
        ok = J >= CRUSHED_J
        for c in range(6):
            if not math.isfinite(pk2[e, c]):
                ok = False
        if ok:
            prho[p] = me / (J * vol0[e])
            # sigma = F S F^T / J, S symmetric (xx, yy, zz, xy, yz, zx)
            s00 = pk2[e, 0]
            s11 = pk2[e, 1]
            s22 = pk2[e, 2]
            s01 = pk2[e, 3]
            s12 = pk2[e, 4]
            s02 = pk2[e, 5]
            # T = F S
            t00 = f00 * s00 + f01 * s01 + f02 * s02
            t01 = f00 * s01 + f01 * s11 + f02 * s12
            t02 = f00 * s02 + f01 * s12 + f02 * s22
            t10 = f10 * s00 + f11 * s01 + f12 * s02
            t11 = f10 * s01 + f11 * s11 + f12 * s12
            t12 = f10 * s02 + f11 * s12 + f12 * s22
            t20 = f20 * s00 + f21 * s01 + f22 * s02
            t21 = f20 * s01 + f21 * s11 + f22 * s12
            t22 = f20 * s02 + f21 * s12 + f22 * s22
            iJ = 1.0 / J
            psig[0, p] = iJ * (t00 * f00 + t01 * f01 + t02 * f02)
            psig[1, p] = iJ * (t10 * f10 + t11 * f11 + t12 * f12)
            psig[2, p] = iJ * (t20 * f20 + t21 * f21 + t22 * f22)
            psig[3, p] = iJ * (t00 * f10 + t01 * f11 + t02 * f12)
            psig[4, p] = iJ * (t10 * f20 + t11 * f21 + t12 * f22)
            psig[5, p] = iJ * (t00 * f20 + t01 * f21 + t02 * f22)
        else:
            prho[p] = me / (CRUSHED_J * vol0[e])
            for c in range(6):
                psig[c, p] = 0.0
            out[2] += 1.0
        out[0] += ke - 0.5 * me * (vx * vx + vy * vy + vz * vz)
        out[1] += ke


@dataclass
class Conversion3D:
    """The particles of a 3D engine's failed elements: ``particles`` (grows as elements convert),
    ``particle_elem[p]`` the element of particle p, ``converted[e]`` whether element e has converted
    (an element converts once), the kinetic energy lost and the one the nodes gave up [J]."""

    particles: pp.Particles3D
    sph_mat: np.ndarray
    converted: np.ndarray
    particle_elem: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    e_conversion: float = 0.0
    ke_from_nodes: float = 0.0
    n_crushed: int = 0

    def convert(self, state, failed) -> np.ndarray:
        """Convert the elements ``failed`` of the 3D engine ``state`` (those not converted yet); returns the
        new particles' indices."""
        ids = np.unique(np.asarray(failed, np.int64))
        ne = state.hexes.shape[0]
        if ids.size and (ids[0] < 0 or ids[-1] >= ne):
            raise ValueError(f"failed element ids must lie in [0, {ne})")
        ids = ids[~self.converted[ids]]
        k = ids.size
        if k == 0:
            return np.zeros(0, np.int64)
        master = np.arange(state.x.shape[1], dtype=np.int64)
        if state.tie_s.size:
            master[state.tie_s] = state.tie_m
        px = np.zeros((3, k))
        pv = np.zeros((3, k))
        pm = np.zeros(k)
        prho = np.zeros(k)
        psig = np.zeros((6, k))
        out = np.zeros(3)
        convert_hexes(ids, state.hexes, state.mat, state.rho, state.vol0, state.b0, state.x, state.v, state.pk2,
                      state.mass, state.meff, state.cmass, master, px, pv, pm, prho, psig, out)
        new = pp.append(self.particles, px, pv, pm, prho, psig, self.sph_mat[state.mat[ids]])
        self.converted[ids] = True
        self.particle_elem = np.concatenate([self.particle_elem, ids])
        self.e_conversion += float(out[0])
        self.ke_from_nodes += float(out[1])
        self.n_crushed += int(out[2])
        return new


def start(state, mats: np.ndarray, prm: np.ndarray, sph_mat=None) -> Conversion3D:
    """An empty conversion for the 3D engine ``state``: SPH material table ``mats`` (isotropic rows of
    :mod:`solver.sph.materials`), parameters ``prm`` (:func:`solver.sph3d.particles.make_params`),
    ``sph_mat[m]`` the SPH row of engine material m (default: row m)."""
    nm = state.rho.shape[0]
    sm = np.arange(nm, dtype=np.int32) if sph_mat is None else np.asarray(sph_mat, np.int32)
    if sm.shape != (nm,) or sm.min() < 0 or sm.max() >= np.atleast_2d(mats).shape[0]:
        raise ValueError(f"sph_mat: need {nm} rows of the SPH material table")
    return Conversion3D(pp.allocate(0, mats, prm), sm, np.zeros(state.hexes.shape[0], bool))
