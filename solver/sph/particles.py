"""The particle container: structure of arrays, SI units, plane strain with unit width.

All per-particle floats live in the rows of one contiguous float64 array ``F`` (row r is the
contiguous field r over all particles; the row names are the constants below), the integer flags
in the rows of an int32 array ``I``. Kernels index ``F[ROW, i]``; no Python objects cross into
compiled code. Particles are either *active* (take part in SPH) or *dormant* (slaved to a finite
element until it fails, see :mod:`solver.sph.conversion`); only the active ones are listed in
``act[:n_act]`` and enter the neighbour search.

Stress convention: tension positive. ``SXX, SYY, SXY`` hold the state stress (the stress of the
damaged-in-stiffness material before the tensile damage ``DMG`` is applied); ``ESXX, ESYY, ESXY``
the effective stress that acts (tensile principal parts times (1 - DMG)). ``I[FIXED]`` is a bit
mask: bit 0 holds the x velocity, bit 1 the y velocity at its current value (clamps, symmetry).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import materials as mt
from ..threads import ThreadChoice
from .kernel import SUPPORT, w_cubic

# float rows of F
(X, Y, VX, VY, AX, AY, M, RHO, SXX, SYY, SXY, ESXX, ESYY, ESXY, RXX, RYY, RXY, CS, THETA, DMG, KAPPA,
 EST, EVI, EAR, RMIN, LXX, LXY, LYX, LYY, FXE, FYE, BXX, BXY, BYX, BYY, FXT, FYT, AVX, AVY, ASX, ASY) = range(41)
NF = 41
FLOAT_ROWS = ("x", "y", "vx", "vy", "ax", "ay", "m", "rho", "sxx", "syy", "sxy", "esxx", "esyy", "esxy",
              "rxx", "ryy", "rxy", "cs", "theta", "dmg", "kappa", "e_strain", "e_visc", "e_artstress",
              "rmin", "lxx", "lxy", "lyx", "lyy", "fx_ext", "fy_ext", "bxx", "bxy", "byx", "byy",
              "fx_tool", "fy_tool", "ax_visc", "ay_visc", "ax_artstress", "ay_artstress")
# int rows of I
MAT, ACTIVE, FIXED = range(3)
NI = 3
# scratch columns: S[k, G*] holds the gathered copies of particle k of the cell order, one row per
# particle (particle-major, unlike F: the pair loops read all fields of a neighbour at once, and
# particle-major they share cache lines: momentum 217 -> 181 ns per particle at 1e5 particles)
GX, GY, GVX, GVY, GM, GRHO, GPXX, GPYY, GPXY, GRXX, GRYY, GRXY, GCS, GBXX, GBXY, GBYX, GBYY = range(17)
NS = 17
# parameters
P_H, P_DP, P_ALPHA, P_BETA, P_EPS, P_NEXP, P_WDP, P_CFL, P_CORR, P_QUAD = range(10)
NP = 10


@dataclass
class Particles:
    """SPH particles (SoA). ``h`` is one smoothing length for all; ``dp`` the reference spacing."""

    F: np.ndarray
    I: np.ndarray
    mats: np.ndarray
    prm: np.ndarray
    S: np.ndarray
    act: np.ndarray  # int64 indices of the active particles (first n_act entries valid)
    n_act: int = 0
    time: float = 0.0
    steps: int = 0
    e_conversion: float = 0.0  # kinetic energy lost at conversions (booked, >= 0)
    forces_valid: bool = False  # F[AX], F[AY] hold the accelerations of the current state
    scratch: dict = field(default_factory=dict)
    #: the threads the compiled chunks run on, chosen by timing them (:mod:`solver.threads`)
    threads: ThreadChoice = field(default_factory=ThreadChoice)
    #: mirror clamp (solver.sph.boundary): int64[3, n_g] ghost and partner indices and float64[4, n_g]
    #: reflection points and stress weights; None for scenes without one (no arrays allocated)
    mirror_idx: np.ndarray | None = None
    mirror_c: np.ndarray | None = None
    #: quadratic-complete surface gradient (solver.sph.quadratic): float64[n, 11] per particle (flag,
    #: coefficients), allocated only when prm[P_QUAD] > 0
    quad: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(self.F.shape[1])

    @property
    def h(self) -> float:
        return float(self.prm[P_H])

    def row(self, name: str) -> np.ndarray:
        return self.F[FLOAT_ROWS.index(name)]

    def active_indices(self) -> np.ndarray:
        return self.act[: self.n_act]

    def refresh_active(self) -> None:
        """Rebuild ``act`` from the ACTIVE flags (after activations made outside compiled code)."""
        idx = np.flatnonzero(self.I[ACTIVE] != 0)
        self.act[: idx.size] = idx
        self.n_act = int(idx.size)
        self.forces_valid = False

    def set_mirror(self, idx: np.ndarray, centre: np.ndarray) -> None:
        """Make particles idx[0] mirror ghosts of idx[1] (stress continued from idx[1], idx[2]) with the
        reflection points and weights ``centre`` (:func:`solver.sph.boundary.mirror_ghosts`,
        :func:`solver.sph.boundary.mirror_stress`; built by :func:`solver.sph.boundary.mirror_pairs`):
        held FIXED, placed after every drift, their stress continued after every update."""
        from .boundary import mirror_ghosts, mirror_stress

        self.mirror_idx = np.ascontiguousarray(idx, np.int64)
        self.mirror_c = np.ascontiguousarray(centre, np.float64)
        self.I[FIXED, self.mirror_idx[0]] = 3
        mirror_ghosts(self.F, self.mirror_idx, self.mirror_c)
        mirror_stress(self.F, self.mirror_idx, self.mirror_c)
        self.forces_valid = False

    def body_indices(self) -> np.ndarray:
        """The active particles that are not mirror ghosts."""
        a = self.active_indices()
        if self.mirror_idx is None:
            return a
        return a[~np.isin(a, self.mirror_idx[0])]

    def nbytes(self) -> int:
        return int(self.F.nbytes + self.I.nbytes + self.S.nbytes + self.act.nbytes + self.mats.nbytes)

    # ------------------------------------------------------------------ energies
    def energies(self) -> dict[str, float]:
        """Kinetic, stress work (internal), viscous and artificial-stress work, conversion loss [J/m]."""
        a = self.active_indices()
        F = self.F
        if self.mirror_idx is not None:  # a mirror ghost's motion and work are images, not energy
            keep = np.ones(self.n, bool)
            keep[self.mirror_idx[0]] = False
            a = a[keep[a]]
            est, evi, ear = float(F[EST, keep].sum()), float(F[EVI, keep].sum()), float(F[EAR, keep].sum())
        else:
            est, evi, ear = float(F[EST].sum()), float(F[EVI].sum()), float(F[EAR].sum())
        ke = 0.5 * float(np.sum(F[M, a] * (F[VX, a] ** 2 + F[VY, a] ** 2)))
        return {"kinetic": ke, "internal": est, "viscous": evi, "artificial_stress": ear,
                "conversion": self.e_conversion, "total": ke + est + evi + ear + self.e_conversion}

    def momentum(self) -> tuple[float, float]:
        a = self.active_indices()
        return float(np.sum(self.F[M, a] * self.F[VX, a])), float(np.sum(self.F[M, a] * self.F[VY, a]))

    def min_distance_ratio(self) -> float:
        """Smallest nearest-neighbour distance over the active particles / dp (clumping check)."""
        a = self.active_indices()
        if a.size == 0:
            return math.inf
        return float(self.F[RMIN, a].min() / self.prm[P_DP])


def make_params(dp: float, h_factor: float = 1.3, alpha: float = 1.0, beta: float = 1.0,
                eps: float = 0.3, n_exp: float = 4.0, cfl: float = 0.3, corrected: bool = True,
                quadratic: float = 0.0) -> np.ndarray:
    """Parameter vector: smoothing length h = h_factor dp, Monaghan viscosity (alpha, beta),
    Gray-Monaghan-Swift artificial stress (eps, n, W(dp)), Courant factor, and whether the stress
    terms use the first-order kernel-gradient correction (Randles & Libersky 1996; Bonet & Lok 1999).
    ``quadratic`` > 0: the particles whose moment matrix has a smallest singular value below it (a cut
    support: free surfaces) use the quadratic-complete gradient of :mod:`solver.sph.quadratic`
    (0, the default: off)."""
    for name, v, lo in (("dp", dp, 0.0), ("h_factor", h_factor, 0.0), ("cfl", cfl, 0.0)):
        if not (v > lo and math.isfinite(v)):
            raise ValueError(f"{name} = {v!r}: must be finite and > {lo}")
    if not (n_exp >= 1 and float(n_exp).is_integer()):
        raise ValueError(f"n_exp = {n_exp!r}: the artificial-stress exponent must be an integer >= 1 (Gray et al.: 4)")
    for name, v in (("alpha", alpha), ("beta", beta), ("eps", eps), ("quadratic", quadratic)):
        if not (v >= 0 and math.isfinite(v)):
            raise ValueError(f"{name} = {v!r}: must be finite and >= 0")
    h = h_factor * dp
    prm = np.zeros(NP)
    prm[P_H], prm[P_DP], prm[P_ALPHA], prm[P_BETA] = h, dp, alpha, beta
    prm[P_EPS], prm[P_NEXP], prm[P_WDP], prm[P_CFL] = eps, n_exp, w_cubic(dp, h), cfl
    prm[P_CORR] = 1.0 if corrected else 0.0
    prm[P_QUAD] = quadratic
    return prm


def allocate(n: int, mats: np.ndarray, prm: np.ndarray) -> Particles:
    """``n`` dormant particles (all zero) with the material table and parameters."""
    F = np.zeros((NF, n))
    F[RMIN] = math.inf
    F[BXX] = 1.0
    F[BYY] = 1.0
    I = np.zeros((NI, n), np.int32)
    S = np.zeros((n, NS))
    quad = np.zeros((n, 11)) if prm.size > P_QUAD and prm[P_QUAD] > 0.0 else None
    return Particles(F=F, I=I, mats=mats, prm=prm, S=S, act=np.zeros(n, np.int64), quad=quad)


def from_points(x, y, mats: np.ndarray, prm: np.ndarray, mat=0, theta=0.0, vx=0.0, vy=0.0,
                volume=None, fixed=None) -> Particles:
    """Active particles at the points (x, y), each of volume ``volume`` (default dp^2), at the
    material's reference density, with zero stress."""
    x = np.asarray(x, np.float64)
    n = x.size
    P = allocate(n, mats, prm)
    F, I = P.F, P.I
    F[X], F[Y] = x, np.asarray(y, np.float64)
    F[VX], F[VY] = vx, vy
    I[MAT] = mat
    rho0 = mats[I[MAT], mt.M_RHO0]
    vol = prm[P_DP] ** 2 if volume is None else volume
    F[RHO] = rho0
    F[M] = rho0 * vol
    F[THETA] = theta
    F[CS] = np.sqrt(mats[I[MAT], mt.M_CMAX] * (1.0 - mats[I[MAT], mt.M_D0]) / rho0)
    I[ACTIVE] = 1
    if fixed is not None:
        fixed = np.asarray(fixed)
        I[FIXED] = np.where(fixed.astype(bool), 3, 0) if fixed.dtype == bool else fixed.astype(np.int32)
    P.refresh_active()
    return P


def lattice(x0: float, x1: float, y0: float, y1: float, dp: float):
    """Cell-centred square lattice of spacing dp filling [x0, x1] x [y0, y1]."""
    nx = max(1, int(round((x1 - x0) / dp)))
    ny = max(1, int(round((y1 - y0) / dp)))
    xs = x0 + (np.arange(nx) + 0.5) * dp
    ys = y0 + (np.arange(ny) + 0.5) * dp
    X_, Y_ = np.meshgrid(xs, ys, indexing="ij")
    return X_.ravel(), Y_.ravel()


def kernel_support(prm: np.ndarray) -> float:
    return SUPPORT * float(prm[P_H])
