"""The 3D particle container: structure of arrays (component-major, (3, n) and (6, n)), SI units.

Every particle is active (the 3D particles are created when a hexahedron fails,
:mod:`solver.sph3d.conversion`, rather than pre-seeded dormant). Fields:

* ``x``, ``v``, ``a`` (3, n): position, velocity, acceleration; ``av``, ``ar`` (3, n) the viscous and
  the artificial-stress parts of ``a`` (the kicks book their work, :mod:`solver.sph3d.loop`);
* ``m``, ``rho``, ``cs`` (n): mass, density, sound speed; ``mat`` (n) int32 material row;
  ``fix`` (n) int32 bit mask: bit c holds velocity component c at its current value;
* ``sig`` (6, n): the acting Cauchy stress (tension positive) in the order xx, yy, zz, xy, yz, zx;
  ``sst`` (6, n): the state stress before the tensile damage, kept apart once a particle's damage
  has begun (with d = 0 the state is ``sig``); ``dmg`` (2, n): the accumulated tensile strain kappa
  and the damage d (:mod:`solver.sph3d.solid`);
  ``R`` (6, n): the Gray-Monaghan-Swift artificial stress, same order;
* ``L``, ``B`` (9, n): velocity gradient L_ab = dv_a/dx_b and the kernel-gradient correction, row-major;
* ``est`` (n): stress work done on each particle; ``rmin`` (n): nearest-neighbour distance;
* ``en``: [viscous dissipation, artificial-stress work, work of the walls, time, steps].

Materials: rows of the 2D table of :mod:`solver.sph.materials` built by its ``isotropic`` (an
isotropic row's plane-strain coefficients C11 = lambda + 2G, C12 = lambda, C66 = G are the 3D Lame
constants, and CMAX = lambda + 2G the 3D P-wave modulus); only isotropic rows are accepted
(:func:`check_materials`). D0 scales the stiffness, as in 2D.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..sph import materials as mt
from ..threads import ThreadChoice
from .kernel import SUPPORT, w_cubic3

# parameters
P_H, P_DP, P_ALPHA, P_BETA, P_EPS, P_NEXP, P_WDP, P_CFL, P_CORR = range(9)
NP = 9
# energy / clock slots of Particles3D.en
E_VISC, E_ART, E_WALL, E_TIME, E_STEPS = range(5)
# columns of the gathered (cell-ordered, particle-major) scratch S[k, G*]: position, velocity, mass,
# density, sound speed, Q = sigma / rho^2 . B (row-major), the artificial stress R (Voigt)
(GX, GY, GZ, GVX, GVY, GVZ, GM, GRHO, GCS, GQ0, GQ1, GQ2, GQ3, GQ4, GQ5, GQ6, GQ7, GQ8,
 GR0, GR1, GR2, GR3, GR4, GR5) = range(24)
NS = 24
# columns of the per-chunk pair accumulators: the gradient pass's sum_j m (v_j - v_i) (x) g (9) and
# -sum_j m d (x) g (6, symmetric: d (x) d); the momentum pass's a, a_visc, a_art (9)
NACC = 15
#: the per-particle arrays of :class:`Particles3D` (last axis the particle), grown and cut together
PER_PARTICLE = ("x", "v", "a", "av", "ar", "m", "rho", "cs", "mat", "fix", "sig", "sst", "dmg", "R", "L", "B", "est",
                "rmin")


def make_params(dp: float, h_factor: float = 1.3, alpha: float = 1.0, beta: float = 1.0, eps: float = 0.3,
                n_exp: float = 4.0, cfl: float = 0.3, corrected: bool = True) -> np.ndarray:
    """Parameter vector, as 2D's :func:`solver.sph.particles.make_params`: h = h_factor dp, Monaghan
    viscosity (alpha, beta), artificial stress (eps, n, W(dp) with the 3D kernel), Courant factor,
    first-order kernel-gradient correction on/off."""
    for name, v, lo in (("dp", dp, 0.0), ("h_factor", h_factor, 0.0), ("cfl", cfl, 0.0)):
        if not (v > lo and math.isfinite(v)):
            raise ValueError(f"{name} = {v!r}: must be finite and > {lo}")
    if not (n_exp >= 1 and float(n_exp).is_integer()):
        raise ValueError(f"n_exp = {n_exp!r}: the artificial-stress exponent must be an integer >= 1 (Gray et al.: 4)")
    for name, v in (("alpha", alpha), ("beta", beta), ("eps", eps)):
        if not (v >= 0 and math.isfinite(v)):
            raise ValueError(f"{name} = {v!r}: must be finite and >= 0")
    h = h_factor * dp
    prm = np.zeros(NP)
    prm[P_H], prm[P_DP], prm[P_ALPHA], prm[P_BETA] = h, dp, alpha, beta
    prm[P_EPS], prm[P_NEXP], prm[P_WDP], prm[P_CFL] = eps, n_exp, w_cubic3(dp, h), cfl
    prm[P_CORR] = 1.0 if corrected else 0.0
    return prm


def check_materials(mats: np.ndarray) -> None:
    """Every row isotropic (C11 = C22 = C12 + 2 C66): the 3D update uses lambda = C12, G = C66."""
    for r, row in enumerate(np.atleast_2d(mats)):
        c11, c12, c22, c66 = row[mt.M_C11], row[mt.M_C12], row[mt.M_C22], row[mt.M_C66]
        if abs(c11 - c22) > 1e-12 * c11 or abs(c11 - c12 - 2 * c66) > 1e-12 * c11:
            raise ValueError(f"material row {r}: not isotropic (C11={c11:g}, C22={c22:g}, C12={c12:g}, C66={c66:g}); "
                             "the 3D particles take isotropic rows (solver.sph.materials.isotropic)")


@dataclass
class Particles3D:
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    av: np.ndarray
    ar: np.ndarray
    m: np.ndarray
    rho: np.ndarray
    cs: np.ndarray
    mat: np.ndarray
    fix: np.ndarray
    sig: np.ndarray
    sst: np.ndarray
    dmg: np.ndarray
    R: np.ndarray
    L: np.ndarray
    B: np.ndarray
    est: np.ndarray
    rmin: np.ndarray
    mats: np.ndarray
    prm: np.ndarray
    #: frictionless penalty planes (:mod:`solver.sph3d.walls`): (n_w, 7) point, unit outward normal (into
    #: the body's side), stiffness per unit mass k [1/s^2]
    walls: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    en: np.ndarray = field(default_factory=lambda: np.zeros(5))
    forces_valid: bool = False
    scratch: dict = field(default_factory=dict)
    #: the threads the compiled chunks run on, chosen by timing them (:mod:`solver.threads`)
    threads: ThreadChoice = field(default_factory=ThreadChoice)

    @property
    def n(self) -> int:
        return int(self.x.shape[1])

    @property
    def h(self) -> float:
        return float(self.prm[P_H])

    @property
    def time(self) -> float:
        return float(self.en[E_TIME])

    @property
    def steps(self) -> int:
        return int(self.en[E_STEPS])

    def momentum(self) -> np.ndarray:
        return (self.m[None, :] * self.v).sum(axis=1)

    def energies(self) -> dict[str, float]:
        """Kinetic, stress work, viscous dissipation, artificial-stress work, the walls' work [J]; total =
        kinetic + stress work + viscous + artificial stress - walls' work (conserved up to the time
        integration error of the stress)."""
        ke = 0.5 * float(np.sum(self.m * np.sum(self.v * self.v, axis=0)))
        est = float(self.est.sum())
        evi, ear, ew = float(self.en[E_VISC]), float(self.en[E_ART]), float(self.en[E_WALL])
        return {"kinetic": ke, "internal": est, "viscous": evi, "artificial_stress": ear, "walls_work": ew,
                "total": ke + est + evi + ear - ew}

    def min_distance_ratio(self) -> float:
        return float(self.rmin.min() / self.prm[P_DP]) if self.n else math.inf


def allocate(n: int, mats: np.ndarray, prm: np.ndarray) -> Particles3D:
    mats = np.ascontiguousarray(np.atleast_2d(mats), np.float64)
    check_materials(mats)
    z3 = lambda: np.zeros((3, n))  # noqa: E731
    B = np.zeros((9, n))
    B[0] = B[4] = B[8] = 1.0
    return Particles3D(x=z3(), v=z3(), a=z3(), av=z3(), ar=z3(), m=np.zeros(n), rho=np.zeros(n), cs=np.zeros(n),
                       mat=np.zeros(n, np.int32), fix=np.zeros(n, np.int32), sig=np.zeros((6, n)),
                       sst=np.zeros((6, n)), dmg=np.zeros((2, n)), R=np.zeros((6, n)), L=np.zeros((9, n)), B=B, est=np.zeros(n), rmin=np.full(n, math.inf),
                       mats=mats, prm=np.ascontiguousarray(prm, np.float64))


def sound_speed(mats: np.ndarray, mat: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """sqrt(CMAX (1 - D0) / rho): the P-wave speed of the (damaged-in-stiffness) isotropic solid."""
    return np.sqrt(mats[mat, mt.M_CMAX] * (1.0 - mats[mat, mt.M_D0]) / rho)


def from_points(x, mats: np.ndarray, prm: np.ndarray, mat=0, v=None, volume=None, fixed=None) -> Particles3D:
    """Particles at the points x (3, n), each of volume ``volume`` (default dp^3), at the material's
    reference density, with zero stress."""
    x = np.ascontiguousarray(x, np.float64)
    n = x.shape[1]
    P = allocate(n, mats, prm)
    P.x[:] = x
    if v is not None:
        P.v[:] = v
    P.mat[:] = mat
    rho0 = P.mats[P.mat, mt.M_RHO0]
    vol = prm[P_DP] ** 3 if volume is None else volume
    P.rho[:] = rho0
    P.m[:] = rho0 * vol
    P.cs[:] = sound_speed(P.mats, P.mat, P.rho)
    if fixed is not None:
        P.fix[:] = np.asarray(fixed, np.int32)
    return P


def append(P: Particles3D, x, v, m, rho, sig, mat) -> np.ndarray:
    """Add particles (positions x (3, k), velocities (3, k), masses, densities, stresses (6, k), material
    rows) to P in place (the arrays grow); returns their indices."""
    k = np.asarray(m).size
    n0 = P.n
    Q = allocate(k, P.mats, P.prm)
    Q.x[:] = x
    Q.v[:] = v
    Q.m[:] = m
    Q.rho[:] = rho
    Q.sig[:] = sig
    Q.mat[:] = mat
    Q.cs[:] = sound_speed(P.mats, Q.mat, Q.rho)
    for name in PER_PARTICLE:
        setattr(P, name, np.ascontiguousarray(np.concatenate([getattr(P, name), getattr(Q, name)], axis=-1)))
    P.forces_valid = False
    P.scratch.clear()
    return np.arange(n0, n0 + k)


def lattice3(lo, hi, dp: float) -> np.ndarray:
    """Cell-centred cubic lattice of spacing dp filling the box [lo, hi] (3 corners): (3, n)."""
    axes = []
    for a, b in zip(lo, hi):
        k = max(1, int(round((b - a) / dp)))
        axes.append(a + (np.arange(k) + 0.5) * dp)
    g = np.meshgrid(*axes, indexing="ij")
    return np.vstack([c.ravel() for c in g])


def kernel_support(prm: np.ndarray) -> float:
    return SUPPORT * float(prm[P_H])
