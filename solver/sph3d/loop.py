"""The compiled, chunked kick-drift-kick (velocity Verlet) time loop of 3D solid SPH, and its driver.

One step (Monaghan 2005 sec. 6; the 2D loop of :mod:`solver.sph.loop`):

    v^{n+1/2} = v^n + dt/2 a^n                 (kick; a held component keeps its velocity)
    x^{n+1}   = x^n + dt v^{n+1/2}             (drift)
    cells(x^{n+1}); L, neighbour list from v^{n+1/2}      (solid.gradient_pass)
    rho, sigma <- advanced by dt                          (solid.update_state)
    a^{n+1}   = momentum(sigma^{n+1}, x^{n+1}, v^{n+1/2}) + walls(x^{n+1})
    v^{n+1}   = v^{n+1/2} + dt/2 a^{n+1}       (kick)

Each half-kick books the work of the viscous and artificial-stress parts of a and of the walls:
the kinetic energy changes by exactly m a . (v + v') dt / 4, which splits linearly over the parts
of a (as 2D's ``_kick_one``), so what is booked is what the integrator moved.

:func:`advance` runs ``n_steps`` of these in compiled code; :func:`step_chunk` calls it with the
particle container's arrays; :func:`run` chooses the signal-speed step dt = cfl min h/(c + |v|)
(and at most WALL_OMEGA_DT / sqrt(k) with walls), advances in chunks and samples histories.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from ..sph.loop import History
from ..threads import run_on
from .cells import NSTEN, build_cells3
from .kernel import SUPPORT
from .particles import E_ART, E_STEPS, E_TIME, E_VISC, E_WALL, NS, P_ALPHA, P_BETA, P_CFL, P_CORR, P_EPS, P_H, P_NEXP, P_WDP, Particles3D
from .solid import (finish_gradient, finish_momentum, gather_kinematics, gather_stress, gradient_pass, momentum_pass,
                    pair_buffers, signal_dt, update_state)
from .walls import WALL_OMEGA_DT, wall_accel

OK, NAN, DISPERSED = 0, 1, 2
STATUS_TEXT = {OK: "ok", NAN: "non-finite particle state (NaN/inf)",
               DISPERSED: "particles dispersed beyond the neighbour grid budget"}
#: initial width of the half neighbour list (a cubic lattice at h = 1.3 dp has 80 neighbours within 2h,
#: a row holds the later half of them: 40 to 52)
NBR_CAP = 64


@numba.njit(cache=True, inline="always")
def _kick_component(v, a, av, ar, c, i, half_dt, wall, sv, sa, sw):
    """v' = v + dt/2 a on component c of particle i; (v + v') times the viscous (av), artificial-stress (ar)
    and wall (``wall``) accelerations added to the three work sums of :func:`kick`."""
    v0 = v[c, i]
    v1 = v0 + half_dt * a[c, i]
    v[c, i] = v1
    s = v0 + v1
    return sv + av[c, i] * s, sa + ar[c, i] * s, sw + wall * s


@numba.njit(parallel=True, cache=True)
def kick(x, v, a, av, ar, m, fix, walls, half_dt, dt_drift):
    """v += dt/2 a on the free components, then (dt_drift > 0) x += dt_drift v. Returns the viscous
    dissipation, the artificial stress's dissipation and the walls' work of this half-kick,
    -m a_v . (v + v') dt/4, -m a_R . (v + v') dt/4, m a_w . (v + v') dt/4 summed."""
    ev = 0.0
    ea = 0.0
    ew = 0.0
    has_walls = walls.shape[0] > 0
    for i in prange(x.shape[1]):
        fx = fix[i]
        wx = 0.0
        wy = 0.0
        wz = 0.0
        if has_walls:
            wx, wy, wz = wall_accel(x[0, i], x[1, i], x[2, i], walls)
        sv = 0.0
        sa = 0.0
        sw = 0.0
        if (fx & 1) == 0:
            sv, sa, sw = _kick_component(v, a, av, ar, 0, i, half_dt, wx, sv, sa, sw)
        if (fx & 2) == 0:
            sv, sa, sw = _kick_component(v, a, av, ar, 1, i, half_dt, wy, sv, sa, sw)
        if (fx & 4) == 0:
            sv, sa, sw = _kick_component(v, a, av, ar, 2, i, half_dt, wz, sv, sa, sw)
        cc = 0.5 * half_dt * m[i]
        ev -= cc * sv
        ea -= cc * sa
        ew += cc * sw
        if dt_drift > 0.0:
            x[0, i] += dt_drift * v[0, i]
            x[1, i] += dt_drift * v[1, i]
            x[2, i] += dt_drift * v[2, i]
    return ev, ea, ew


@numba.njit(cache=True)
def booked_kick(x, v, a, av, ar, m, fix, walls, half_dt, dt_drift, en):
    """:func:`kick`, its viscous and artificial-stress dissipation and the walls' work added to ``en``."""
    ev, ea, ew = kick(x, v, a, av, ar, m, fix, walls, half_dt, dt_drift)
    en[E_VISC] += ev
    en[E_ART] += ea
    en[E_WALL] += ew


@numba.njit(cache=True)
def forces(x, v, a, av, ar, m, rho, cs, mat, sig, sst, dmg, R, L, B, est, rmin, mats, prm, walls, S, order, cell_of, nbr, nfw, nfn,
           cnt, A, dt):
    """Cells, the gradient pass (L, B, the half neighbour list), the state advanced by dt (dt = 0: only
    R and the sound speed refreshed) and the momentum pass. Returns (ok, nbr, nfw, nfn): the list
    enlarged when a row was full."""
    n = x.shape[1]
    h = prm[P_H]
    start, ncx, ncy, ncz, x0, y0, z0, cell, ok = build_cells3(x, n, SUPPORT * h / NSTEN, order, cell_of)
    if not ok:
        return False, nbr, nfw, nfn
    gather_kinematics(x, v, m, rho, S, order, n)
    nexp = int(prm[P_NEXP])
    worst = gradient_pass(S, n, start, ncx, ncy, ncz, x0, y0, z0, cell, h, prm[P_WDP], nexp, nbr, nfw, nfn, cnt, A)
    if worst > nbr.shape[1]:
        nbr = np.empty((n, worst + 8), np.int32)
        nfw = np.empty((n, worst + 8))
        nfn = np.empty((n, worst + 8))
        gradient_pass(S, n, start, ncx, ncy, ncz, x0, y0, z0, cell, h, prm[P_WDP], nexp, nbr, nfw, nfn, cnt, A)
    finish_gradient(S, order, n, A, prm[P_CORR] > 0.0, L, B, rmin)
    update_state(L, rho, sig, sst, dmg, R, cs, est, m, mat, mats, prm[P_EPS], dt)
    gather_stress(sig, R, rho, cs, B, S, order, n)
    momentum_pass(S, n, nbr, nfw, nfn, cnt, h, prm[P_ALPHA], prm[P_BETA], prm[P_EPS] > 0.0, A)
    finish_momentum(order, n, A, a, av, ar, x, walls)
    return True, nbr, nfw, nfn


@numba.njit(cache=True)
def _finite(x, v):
    for i in range(x.shape[1]):
        for c in range(3):
            if not (math.isfinite(x[c, i]) and math.isfinite(v[c, i])):
                return False
    return True


@numba.njit(cache=True)
def advance(x, v, a, av, ar, m, rho, cs, mat, fix, sig, sst, dmg, R, L, B, est, rmin, mats, prm, walls, en, S, order, cell_of,
            nbr, nfw, nfn, cnt, A, n_steps, dt):
    """``n_steps`` kick-drift-kick steps of size dt (module docstring). Returns (status, steps done, nbr,
    nfw, nfn)."""
    half = 0.5 * dt
    done = 0
    for _ in range(n_steps):
        booked_kick(x, v, a, av, ar, m, fix, walls, half, dt, en)
        ok, nbr, nfw, nfn = forces(x, v, a, av, ar, m, rho, cs, mat, sig, sst, dmg, R, L, B, est, rmin, mats, prm, walls, S,
                                   order, cell_of, nbr, nfw, nfn, cnt, A, dt)
        if not ok:
            return (NAN if not _finite(x, v) else DISPERSED), done, nbr, nfw, nfn
        booked_kick(x, v, a, av, ar, m, fix, walls, half, 0.0, en)
        en[E_TIME] += dt
        en[E_STEPS] += 1.0
        done += 1
    if not _finite(x, v):
        return NAN, done, nbr, nfw, nfn
    return OK, done, nbr, nfw, nfn


def _buffers(P: Particles3D):
    s = P.scratch
    if "order" not in s or s["order"].size != P.n:
        s["order"] = np.zeros(P.n, np.int64)
        s["cell_of"] = np.zeros(P.n, np.int64)
        s["S"] = np.zeros((P.n, NS))
        s["nbr"] = np.zeros((P.n, NBR_CAP), np.int32)
        s["nfw"] = np.zeros((P.n, NBR_CAP))
        s["nfn"] = np.zeros((P.n, NBR_CAP))
        s["cnt"] = np.zeros(P.n, np.int64)
        s["A"] = pair_buffers(P.n, numba.config.NUMBA_NUM_THREADS)
    return s


def _args(P: Particles3D):
    s = _buffers(P)
    return (P.x, P.v, P.a, P.av, P.ar, P.m, P.rho, P.cs, P.mat, P.fix, P.sig, P.sst, P.dmg, P.R, P.L, P.B, P.est, P.rmin, P.mats,
            P.prm, np.ascontiguousarray(P.walls, np.float64), P.en, s["S"], s["order"], s["cell_of"], s["nbr"], s["nfw"], s["nfn"],
            s["cnt"], s["A"])


def prime(P: Particles3D) -> None:
    """Compute the accelerations of the current state (after building or adding particles)."""
    if P.n == 0:
        P.forces_valid = True
        return
    s = _buffers(P)
    ok, s["nbr"], s["nfw"], s["nfn"] = forces(P.x, P.v, P.a, P.av, P.ar, P.m, P.rho, P.cs, P.mat, P.sig, P.sst, P.dmg, P.R, P.L, P.B,
                                              P.est, P.rmin, P.mats, P.prm, np.ascontiguousarray(P.walls, np.float64),
                                              s["S"], s["order"], s["cell_of"], s["nbr"], s["nfw"], s["nfn"], s["cnt"],
                                              s["A"], 0.0)
    if not ok:
        raise FloatingPointError("3D SPH neighbour grid could not be built: non-finite positions")
    P.forces_valid = True


def stable_dt(P: Particles3D) -> float:
    """cfl x min h / (c + |v|), and at most WALL_OMEGA_DT / sqrt(k) of the stiffest wall (inf when empty)."""
    if P.n == 0:
        return math.inf
    dt = float(P.prm[P_CFL]) * signal_dt(P.v, P.cs, P.h)
    if P.walls.shape[0]:
        dt = min(dt, WALL_OMEGA_DT / math.sqrt(float(P.walls[:, 6].max())))
    return dt


@dataclass
class StepReport:
    steps: int
    status: str


def step_chunk(P: Particles3D, n_steps: int, dt: float, threads: int | None = None) -> StepReport:
    """Advance P by up to n_steps steps of size dt in compiled code. threads: numba threads for this call
    (default: those ``P.threads`` finds faster, :class:`solver.threads.ThreadChoice`; the results do not
    depend on it)."""
    if P.n == 0:
        P.en[E_TIME] += n_steps * dt
        return StepReport(n_steps, "ok")

    def call():
        if not P.forces_valid:
            prime(P)
        return advance(*_args(P), int(n_steps), float(dt))

    res = P.threads.run(call, steps_of=lambda r: r[1]) if threads is None else run_on(threads, call)
    status, done, P.scratch["nbr"], P.scratch["nfw"], P.scratch["nfn"] = res
    return StepReport(int(done), STATUS_TEXT[int(status)])


def run(P: Particles3D, t_end: float, sample=None, n_samples: int = 200, chunk_steps: int = 200,
        max_wall_s: float = 600.0) -> tuple[History, StepReport]:
    """Advance to t_end with the signal-speed step (re-evaluated every chunk), sampling
    ``sample(P) -> dict`` about n_samples times. Stops at a non-ok status or after max_wall_s."""
    hist = History()
    wall0 = time.perf_counter()
    if not P.forces_valid:
        prime(P)
    if sample is not None:
        hist.add(P.time, **sample(P))
    t_next = t_end / max(1, n_samples)
    status = "ok"
    while P.time < t_end * (1 - 1e-12):
        dt = stable_dt(P)
        n = max(1, min(chunk_steps, int(math.ceil((min(t_next, t_end) - P.time) / dt))))
        rep = step_chunk(P, n, dt)
        if rep.status != "ok":
            status = rep.status
            break
        if sample is not None and P.time >= t_next * (1 - 1e-12):
            hist.add(P.time, **sample(P))
            t_next += t_end / max(1, n_samples)
        if time.perf_counter() - wall0 > max_wall_s:
            status = "wall-time limit"
            break
    return hist, StepReport(P.steps, status)
