"""The compiled, chunked kick-drift-kick (velocity Verlet) time loop of solid SPH, and its driver.

One step (Monaghan 2005 sec. 6; LAMMPS SMD's ulsph integrator has the same shape):

    v^{n+1/2} = v^n + dt/2 a^n                 (kick; a fixed component keeps its velocity)
    x^{n+1}   = x^n + dt v^{n+1/2}             (drift)
    cells(x^{n+1});  L, d rho/dt from v^{n+1/2}
    rho, sigma, theta, D  <- advanced by dt      (solid.update_state)
    a^{n+1}   = momentum(sigma^{n+1}, x^{n+1}, v^{n+1/2})
    v^{n+1}   = v^{n+1/2} + dt/2 a^{n+1}       (kick)

Each half-kick books the work of the viscous and artificial-stress parts of a, of the tool's and of the edges' forces
(:func:`_kick_one`), so the viscous dissipation and the work done on the particles are what the
integrator moved in and out of their kinetic energy.

:func:`advance` runs ``n_steps`` of these in compiled code; :func:`run` is the Python driver that
chooses the signal-speed step dt = cfl min h/(c + |v|), calls ``advance`` in chunks, samples
histories and checks the stability guard between chunks.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numba
import numpy as np
from numba import prange

from .cells import NSTEN, build_cells
from .kernel import SUPPORT
from ..contact import tool_contact
from ..threads import run_on
from .coupling import PAIR_ROWS, expel_from_elements, new_pair_memory, particle_edge_contact
from .particles import ACTIVE, ASX, ASY, AVX, AVY, AX, AY, CS, EAR, EVI, FIXED, FXT, FYT, M, MAT, P_CFL, P_CORR, P_H, P_QUAD, RMIN, VX, VY, X, Y, Particles
from .solid import (gather_kinematics, gather_stress, momentum, pair_buffers, refresh_for_forces, signal_dt, update_state,
                    velocity_gradient)
from .boundary import NO_MIRROR, mirror_ghosts, mirror_stress
from .quadratic import compute_forces_q, momentum_q, velocity_gradient_q

#: the largest omega dt of a particle's penalty oscillator (:func:`stable_dt`)
CONTACT_OMEGA_DT = 1.0

# status codes of advance()
OK, NAN, DISPERSED, DT_COLLAPSE = 0, 1, 2, 3
STATUS_TEXT = {OK: "ok", NAN: "non-finite particle state (NaN/inf)",
               DISPERSED: "particles dispersed beyond the neighbour grid budget",
               DT_COLLAPSE: "signal-speed time step fell below half the step in use"}


@numba.njit(cache=True)
def compute_forces(F, I, S, A, act, n_act, mats, prm, order, cell_of):
    """Cells, refresh of the acting/artificial stress (update_state with dt = 0) and the momentum pass.
    Returns False when the neighbour grid cannot be built."""
    start, ncx, ncy, x0, y0, cell, ok = refresh_for_forces(F, I, S, act, n_act, mats, prm, order, cell_of)
    if ok:
        momentum(F, I, S, A, order, n_act, start, ncx, ncy, x0, y0, cell, prm)
    return ok



@numba.njit(parallel=True, cache=True)
def _kick(F, I, act, n_act, half_dt, dt_drift, fxp, fyp, has_edges):
    """v += dt/2 a on the free components, then, with dt_drift > 0, x += dt_drift v; books the viscous
    and artificial-stress work on each particle and returns the tool's and the edges' work on all of
    them (:func:`_kick_one`)."""
    w_tool = 0.0
    w_edge = 0.0
    for k in prange(n_act):
        i = act[k]
        wt, we = _kick_one(F, I[FIXED, i], i, half_dt, fxp, fyp, has_edges)
        w_tool += wt
        w_edge += we
        if dt_drift > 0.0:
            F[X, i] += dt_drift * F[VX, i]
            F[Y, i] += dt_drift * F[VY, i]
    return w_tool, w_edge


@numba.njit(cache=True, inline="always")
def _kick_component(F, i, V, A, AV, AS, FT, fpe, half_dt, has_edges, wv, wa, wt, we):
    """One free velocity component of particle i (rows V, A, AV, AS, FT of F: the velocity, the
    acceleration, its viscous and artificial-stress parts, the tool force; fpe the edges' penalty) in
    :func:`_kick_one`: v' = v + dt/2 a, and (v + v') times each part added to wv, wa, wt and we (the
    latter with ``has_edges``). Returns the four sums."""
    v0 = F[V, i]
    F[V, i] = v0 + half_dt * F[A, i]
    s = v0 + F[V, i]
    wv += F[AV, i] * s
    wa += F[AS, i] * s
    wt += F[FT, i] * s
    if has_edges != 0:
        we += fpe[i] * s
    return wv, wa, wt, we


@numba.njit(cache=True, inline="always")
def _kick_one(F, fix, i, half_dt, fxp, fyp, has_edges):
    """One particle's half-kick v' = v + dt/2 a on its free components, and the work each part of the
    force does in it. The kinetic energy changes by exactly

        m (v'^2 - v^2) / 2 = m a . (v + v') dt / 4,

    which splits linearly over the parts of m a: the viscous part m a_v (booked here as dissipation,
    E_visc += -m a_v . (v + v') dt / 4), the artificial stress's m a_R (booked here alike), the edges' penalty (fxp, fyp, with ``has_edges``) and the
    rest of the tool forces FXT (returned: the tool's work, the edges' work). So what is booked is
    what the integrator did, whichever velocities a force was computed from, and also when the
    forces or the step change between the two half-kicks of a step (a particle born or gone, a new
    step size for the next sub-chunk), where an end-of-step power F^{n+1} . v^{n+1} dt would not be exact."""
    wv = 0.0
    wa = 0.0
    wt = 0.0
    we = 0.0
    if (fix & 1) == 0:
        wv, wa, wt, we = _kick_component(F, i, VX, AX, AVX, ASX, FXT, fxp, half_dt, has_edges, wv, wa, wt, we)
    if (fix & 2) == 0:
        wv, wa, wt, we = _kick_component(F, i, VY, AY, AVY, ASY, FYT, fyp, half_dt, has_edges, wv, wa, wt, we)
    c = 0.5 * half_dt
    F[EVI, i] -= c * F[M, i] * wv
    F[EAR, i] -= c * F[M, i] * wa
    return c * (wt - we), c * we


@numba.njit(cache=True)
def _finite(F, act, n_act):
    for k in range(n_act):
        i = act[k]
        if not (math.isfinite(F[X, i]) and math.isfinite(F[Y, i]) and math.isfinite(F[VX, i])
                and math.isfinite(F[VY, i])):
            return False
    return True


@numba.njit(cache=True)
def advance(F, I, S, A, act, n_act, mats, prm, order, cell_of, n_steps, dt, out, has_tool, tool, k_pen, tool_by_mass, mu,
            tool_out, has_edges, edges, equads, ex, ey, evx, evy, egrid, estart, eitems, lgrid, lstart, litems, fxp, fyp, fxn, fyn,
            jxn, jyn, e_out, x_out, epairs, enmass, midx, mcen, Q):
    """Run ``n_steps`` kick-drift-kick steps of size dt (module docstring). F[AX], F[AY] must hold the
    accelerations of the current state (see :func:`compute_forces`).

    With ``has_tool`` the rigid tool (the contract's tool array, moved here by tool[2:4] dt each step)
    acts on the active particles through :func:`solver.contact.tool_contact` (penalty k_pen, or k_pen m_i
    of each particle's mass m_i with ``tool_by_mass``; friction mu, its stick/slip trial from the pair
    forces' accelerations) as the forces FXT, FYT (recomputed every step; FXE, FYE stay the caller's
    constant external forces); tool_out accumulates as the contract says (sums over steps; with 10 entries
    also by face of the tool, :func:`solver.contact.tool_contact`).

    With ``has_edges`` the exposed edges of the surviving elements push the particles out
    (:func:`solver.sph.coupling.particle_edge_contact`; egrid = [x0, y0, cell, ncx, ncy, k, r_c,
    v_sep, dt_lim] of the edges' cell list estart/eitems, the separation-speed limit spreading its
    velocity change over max(dt, dt_lim)), every step after the other forces (the limit adds what they
    press into an edge), as part of FXT, FYT and of the accelerations; the nodes' reaction forces
    are summed over the steps into fxn, fyn (with one step: the reactions at the end of it), e_out[0] =
    deepest overlap, e_out[1] += contacts, e_out[2] += the coupling forces' work on the particles (as the tool's),
    e_out[3] += the energy the contact pairs' state changes dropped (the pair memory ``epairs``).
    After each drift a particle found inside a living element (quads ``equads``, the living ones in
    the cell list lgrid, lstart, litems) is put back out, r_c = egrid[6] in front of its boundary
    (:func:`solver.sph.coupling.expel_from_elements`, records in x_out, the nodes' impulses into jxn, jyn).

    out (float64[5]): out[0] = steps done, out[1] = status code (OK, NAN, DISPERSED, DT_COLLAPSE),
    out[2] = smallest signal-speed step h/(c+|v|) seen, out[3] = smallest neighbour distance seen,
    out[4] += work of the tool's forces on the particles [J/m] (summed over the half-kicks, :func:`_kick_one`).

    midx, mcen: the mirror clamp's ghosts, placed from their partners after each drift
    (:func:`solver.sph.boundary.mirror_ghosts`; empty: none). Q (float64[n, 11], empty: off): the
    quadratic-complete surface gradient (:mod:`solver.sph.quadratic`)."""
    h = prm[P_H]
    cell = SUPPORT * h / NSTEN
    half = 0.5 * dt
    out[0] = 0.0
    out[1] = OK
    out[2] = math.inf
    out[3] = math.inf
    for step in range(n_steps):
        wt, we = _kick(F, I, act, n_act, half, dt, fxp, fyp, has_edges)  # and drift
        out[4] += wt
        e_out[2] += we
        if midx.shape[1] > 0:
            mirror_ghosts(F, midx, mcen)
        if has_edges != 0:
            expel_from_elements(F, act, n_act, edges, equads, ex, ey, evx, evy, egrid[0], egrid[1], egrid[2],
                                int(egrid[3]), int(egrid[4]), estart, eitems, lgrid, lstart, litems, True, enmass, jxn,
                                jyn, epairs, egrid[5], egrid[6], tool, has_tool, x_out)
        start, ncx, ncy, x0, y0, cell_k, ok = build_cells(F[X], F[Y], act, n_act, cell, order, cell_of)
        if not ok:
            out[1] = DISPERSED if _finite(F, act, n_act) else NAN
            return
        gather_kinematics(F, S, order, n_act)
        if Q.shape[0] > 0:
            velocity_gradient_q(F, S, Q, order, n_act, start, ncx, ncy, x0, y0, cell_k, h, prm[P_QUAD])
        else:
            velocity_gradient(F, S, order, n_act, start, ncx, ncy, x0, y0, cell_k, h, prm[P_CORR] > 0.0)
        update_state(F, I, act, n_act, mats, prm, dt)
        if midx.shape[1] > 0:
            mirror_stress(F, midx, mcen)
        gather_stress(F, S, order, n_act)
        if has_tool != 0 or has_edges != 0:
            for k in range(n_act):
                F[FXT, act[k]] = 0.0
                F[FYT, act[k]] = 0.0
        if Q.shape[0] > 0:
            momentum_q(F, I, S, A, Q, order, n_act, start, ncx, ncy, x0, y0, cell_k, prm)
        else:
            momentum(F, I, S, A, order, n_act, start, ncx, ncy, x0, y0, cell_k, prm)
        if has_tool != 0:  # after the pair forces: the friction's stick/slip trial sees them (AX, AY)
            tool_contact(F[X], F[Y], F[VX], F[VY], F[M], I[ACTIVE], tool, k_pen, mu, F[FXT], F[FYT], tool_out,
                         tool_by_mass, dt, F[AX], F[AY], 1)
            for k in range(n_act):
                i = act[k]
                F[AX, i] += F[FXT, i] / F[M, i]
                F[AY, i] += F[FYT, i] / F[M, i]
        if has_edges != 0:  # last: its separation-speed limit sees every other force (AX, AY)
            for k in range(n_act):
                fxp[act[k]] = 0.0
                fyp[act[k]] = 0.0
            particle_edge_contact(F, act, n_act, edges, ex, ey, evx, evy, egrid[0], egrid[1], egrid[2],
                                  int(egrid[3]), int(egrid[4]), estart, eitems, egrid[5], egrid[6], egrid[7],
                                  dt, egrid[8], fxp, fyp, fxn, fyn, epairs, e_out)
            for k in range(n_act):
                i = act[k]
                F[FXT, i] += fxp[i]
                F[FYT, i] += fyp[i]
                F[AX, i] += fxp[i] / F[M, i]
                F[AY, i] += fyp[i] / F[M, i]
        wt, we = _kick(F, I, act, n_act, half, 0.0, fxp, fyp, has_edges)
        out[4] += wt
        e_out[2] += we
        if has_tool != 0:
            tool[0] += tool[2] * dt
            tool[1] += tool[3] * dt
        out[0] += 1.0
        if (step & 15) == 15 or step == n_steps - 1:
            sdt = signal_dt(F, act, n_act, h)
            if sdt < out[2]:
                out[2] = sdt
            if not math.isfinite(sdt):
                out[1] = NAN
                return
            if sdt * prm[P_CFL] < 0.5 * dt:
                out[1] = DT_COLLAPSE
                return
    for k in range(n_act):
        r = F[RMIN, act[k]]
        if r < out[3]:
            out[3] = r


def stable_dt(P: Particles, k_per_mass: float = 0.0) -> float:
    """cfl x min h / (c + |v|) over the active particles (inf when none is active); with a penalty of
    k_per_mass [1/s^2] per unit mass (the tool's, :func:`solver.contact.tool_contact` with by_mass)
    also at most CONTACT_OMEGA_DT / sqrt(k_per_mass), so that the penalty oscillator of every particle
    is resolved (central differences are stable for omega dt < 2; the signal-speed step of a particle
    whose stiffness damage took away, 1 - D = 0.01, was 10 times the engine's and put omega dt at 3)."""
    if P.n_act == 0:
        return math.inf
    dt = float(P.prm[P_CFL]) * signal_dt(P.F, P.act, P.n_act, P.h)
    if k_per_mass > 0.0:
        dt = min(dt, CONTACT_OMEGA_DT / math.sqrt(k_per_mass))
    return dt


def _buffers(P: Particles):
    """Neighbour-search order and cells, and the pair accumulators: one per chunk of the symmetric
    pair loops, as many chunks as numba may run threads (fixed per process, so the sums do not depend
    on ``numba.set_num_threads``)."""
    if "order" not in P.scratch or P.scratch["order"].size != P.n:
        P.scratch["order"] = np.zeros(P.n, np.int64)
        P.scratch["cell_of"] = np.zeros(P.n, np.int64)
        P.scratch["pairs"] = pair_buffers(P.n, numba.config.NUMBA_NUM_THREADS)
    return P.scratch["order"], P.scratch["cell_of"], P.scratch["pairs"]


def prime(P: Particles) -> None:
    """Compute the accelerations of the current state (after building or converting particles)."""
    order, cell_of, pairs = _buffers(P)

    def call():
        if P.quad is not None:
            return P.n_act == 0 or compute_forces_q(P.F, P.I, P.S, pairs, P.quad, P.act, P.n_act, P.mats, P.prm, order,
                                                    cell_of)
        return P.n_act == 0 or compute_forces(P.F, P.I, P.S, pairs, P.act, P.n_act, P.mats, P.prm, order, cell_of)

    ok = run_on(P.threads.best, call)  # on the threads the chunks run faster on (step_chunk)
    if not ok:
        raise FloatingPointError("SPH neighbour grid could not be built: particles dispersed or non-finite")
    P.forces_valid = True


def edge_pairs(P: Particles) -> np.ndarray:
    """The particles' contact pair memory with element edges (:func:`solver.sph.coupling.new_pair_memory`),
    kept with them between chunks, allocated on first use."""
    if P.scratch.get("edge_pairs") is None or P.scratch["edge_pairs"].shape[1] != P.n:
        P.scratch["edge_pairs"] = new_pair_memory(P.n)
    return P.scratch["edge_pairs"]


@dataclass
class StepReport:
    steps: int
    time: float
    status: str = "ok"
    finding: str = ""
    min_signal_dt: float = math.inf
    min_distance: float = math.inf
    tool_work: float = 0.0


_NO_TOOL = np.zeros(12)
_NO_QUAD = np.zeros((0, 11))


@dataclass
class EdgeContact:
    """The surviving elements' exposed edges for :func:`advance` (solver.sph.coupling): node pairs
    ``edges`` (with their element) into the node positions x, y and velocities vx, vy (held fixed over
    the chunk), the elements' ``quads``, the edges' cell list (grid = [x0, y0, cell, ncx, ncy, k, r_c,
    v_sep, dt_lim], estart, eitems: :func:`solver.contact._build_cells`), the living elements' cell list (lgrid = [x0, y0, cell, ncx, ncy], lstart,
    litems: :func:`solver.sph.coupling.bin_elements`). After the chunk, fxn, fyn hold the
    nodes' reaction forces summed over its steps [N/m] (one step: the reactions at its end, where the
    particles' coupling forces were found), jxn, jyn the nodes' impulses of the plastic impacts
    [N s/m], out = [deepest overlap, contacts, work on the particles, energy the contact pairs' state
    changes dropped [J/m]] of the penalty and expelled = [particles put back out of an element, largest
    move [m], work on the particles, put on a foot inside another element, with no boundary edge in reach,
    energy the plastic impacts lose (1/2) m v_n^2 summed [J/m], energy the put-back particles' contact
    springs held [J/m]] of the kinematic condition. ``pairs``: the particles' contact pair memory
    (:func:`solver.sph.coupling.new_pair_memory`), filled in by :func:`step_chunk` with the one it keeps
    with the particles (``P.scratch["edge_pairs"]``, allocated on first use)."""
    edges: np.ndarray
    quads: np.ndarray
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    grid: np.ndarray
    estart: np.ndarray
    eitems: np.ndarray
    lgrid: np.ndarray
    lstart: np.ndarray
    litems: np.ndarray
    fxn: np.ndarray = None
    fyn: np.ndarray = None
    jxn: np.ndarray = None
    jyn: np.ndarray = None
    out: np.ndarray = field(default_factory=lambda: np.zeros(4))
    expelled: np.ndarray = field(default_factory=lambda: np.zeros(7))
    pairs: np.ndarray = None
    nmass: np.ndarray = None  # the nodes' masses [kg/m] for the plastic impacts (None: a rigid wall)

    def __post_init__(self):
        if self.fxn is None:
            self.fxn = np.zeros(self.x.size)
            self.fyn = np.zeros(self.x.size)
        if self.jxn is None:
            self.jxn = np.zeros(self.x.size)
            self.jyn = np.zeros(self.x.size)
        if self.nmass is None:
            self.nmass = np.full(self.x.size, np.inf)


_NO_EDGES = (np.zeros((0, 3), np.int32), np.zeros((1, 4), np.int32), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(9),
             np.full(1, -1, np.int64), np.zeros(1, np.int64), np.array([0.0, 0.0, 1.0, 1.0, 1.0]),
             np.zeros(2, np.int64), np.zeros(1, np.int64), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1),
             np.zeros(1), np.zeros(1), np.zeros(4), np.zeros(7), np.zeros((PAIR_ROWS, 1)), np.full(1, np.inf))


def step_chunk(P: Particles, n_steps: int, dt: float, tool=None, k_pen: float = 0.0, mu: float = 0.0,
               tool_out=None, edges: EdgeContact | None = None, tool_by_mass: bool = False,
               threads: int | None = None) -> StepReport:
    """Advance ``n_steps`` compiled steps of size dt; returns steps done and the stability finding.
    ``threads``: numba threads for this call (default: those ``P.threads`` finds faster,
    :class:`solver.threads.ThreadChoice`; the results do not depend on it).
    ``tool`` (the contract's array, moved in place) makes the tool act on the particles; without it
    the tool forces of an earlier chunk are cleared; its penalty is k_pen [N/m per m], or k_pen m_i
    (k_pen in 1/s^2) on a particle of mass m_i with ``tool_by_mass`` (:func:`solver.contact.tool_contact`).
    ``edges`` couples the particles to the surviving elements' edges (:class:`EdgeContact`; its
    reaction forces, impulses and records are filled in)."""
    has_tool = 0 if tool is None else 1
    if tool is None:
        # the tool forces of an earlier chunk no longer act, nor in the accelerations; the edges' part of
        # FXT, FYT (f_edge) does when edges still couple: the first half-kick takes it as the last one did
        fe = P.scratch.get("f_edge") if edges is not None else None
        kx, ky = (0.0, 0.0) if fe is None else (fe[0], fe[1])
        if np.any(P.F[FXT] != kx) or np.any(P.F[FYT] != ky):
            P.F[FXT] = kx
            P.F[FYT] = ky
            P.forces_valid = False
    if not P.forces_valid:
        prime(P)
    order, cell_of, pairs = _buffers(P)
    out = np.zeros(5)
    tl = _NO_TOOL if tool is None else tool
    tout = np.zeros(10) if tool_out is None else tool_out
    def call():
        if edges is None:
            eargs = _NO_EDGES
            if P.scratch.get("f_edge") is not None:
                P.scratch["f_edge"][:] = 0.0  # no edge forces in FXT from here on (the kicks' split)
        else:
            if P.scratch.get("f_edge") is None or P.scratch["f_edge"].shape[1] != P.n:
                P.scratch["f_edge"] = np.zeros((2, P.n))  # the particles' coupling forces, allocated on first use
            fe = P.scratch["f_edge"]
            edges.pairs = edge_pairs(P)
            edges.fxn[:] = 0.0
            edges.fyn[:] = 0.0
            edges.jxn[:] = 0.0
            edges.jyn[:] = 0.0
            eargs = (edges.edges, edges.quads, edges.x, edges.y, edges.vx, edges.vy, edges.grid, edges.estart,
                     edges.eitems, edges.lgrid, edges.lstart, edges.litems, fe[0], fe[1], edges.fxn, edges.fyn,
                     edges.jxn, edges.jyn, edges.out, edges.expelled, edges.pairs, edges.nmass)
        advance(P.F, P.I, P.S, pairs, P.act, P.n_act, P.mats, P.prm, order, cell_of, int(n_steps), float(dt), out,
                has_tool, tl, float(k_pen), int(bool(tool_by_mass)), float(mu), tout, 0 if edges is None else 1, *eargs,
                *(NO_MIRROR if P.mirror_idx is None else (P.mirror_idx, P.mirror_c)),
                _NO_QUAD if P.quad is None else P.quad)
        return int(out[0])

    done = P.threads.run(call) if threads is None else run_on(threads, call)
    P.steps += done
    P.time += done * dt
    code = int(out[1])
    rep = StepReport(done, P.time, "ok" if code == OK else "unstable", "" if code == OK else STATUS_TEXT[code] + _where(P),
                     float(out[2]), float(out[3]), float(out[4]))
    if code != OK:
        P.forces_valid = False
    return rep


def _where(P: Particles) -> str:
    """Where the particles went wrong: the particle with the smallest signal-speed step h / (c + |v|)
    (or the first non-finite one), its position, speed, sound speed, material and nearest neighbour."""
    a = P.active_indices()
    if a.size == 0:
        return ""
    F = P.F
    v = np.hypot(F[VX, a], F[VY, a])
    bad = ~(np.isfinite(F[X, a]) & np.isfinite(F[Y, a]) & np.isfinite(v))
    k = int(np.flatnonzero(bad)[0]) if bad.any() else int(np.argmin(P.h / (F[CS, a] + v)))
    i = int(a[k])
    return (f"; worst particle {i} (material {int(P.I[MAT, i])}) "
            f"at ({F[X, i] * 1e6:.4g}, {F[Y, i] * 1e6:.4g}) um, speed {v[k]:.4g} m/s, sound speed {F[CS, i]:.4g} m/s, "
            f"nearest neighbour {F[RMIN, i] * 1e6:.3g} um")


@dataclass
class History:
    t: list = field(default_factory=list)
    values: dict = field(default_factory=dict)

    def add(self, t: float, **vals):
        self.t.append(t)
        for k, v in vals.items():
            self.values.setdefault(k, []).append(v)

    def arrays(self):
        return np.asarray(self.t), {k: np.asarray(v) for k, v in self.values.items()}


def run(P: Particles, t_end: float, sample=None, n_samples: int = 200, chunk_steps: int = 200,
        max_wall_s: float = 600.0, progress=None) -> tuple[History, StepReport]:
    """Advance P to ``t_end`` with the signal-speed step, in chunks of at most ``chunk_steps`` steps,
    recording ``sample(P) -> dict`` at ``n_samples`` evenly spaced times. ``progress(fraction, msg)``
    returning False cancels. Returns the history and the last report (status ok|unstable|cancelled)."""
    hist = History()
    t0 = P.time
    if sample is not None:
        hist.add(P.time, **sample(P))
    next_sample = t0 + (t_end - t0) / n_samples
    wall0 = time.perf_counter()
    rep = StepReport(0, P.time)
    if not P.forces_valid:
        prime(P)
    while P.time < t_end * (1 - 1e-12):
        dt = stable_dt(P)
        if not math.isfinite(dt) or dt <= 0:
            rep.status, rep.finding = "unstable", "no finite signal-speed step"
            break
        n = max(1, min(chunk_steps, int(math.ceil((next_sample - P.time) / dt))))
        n = min(n, max(1, int(math.ceil((t_end - P.time) / dt))))
        r = step_chunk(P, n, dt)
        rep = r
        if r.status != "ok":
            break
        if P.time >= next_sample * (1 - 1e-12) or P.time >= t_end * (1 - 1e-12):
            if sample is not None:
                hist.add(P.time, **sample(P))
            while next_sample <= P.time * (1 + 1e-12):
                next_sample += (t_end - t0) / n_samples
        if progress is not None and progress((P.time - t0) / (t_end - t0), f"t = {P.time:.4g} s") is False:
            rep.status = "cancelled"
            break
        if time.perf_counter() - wall0 > max_wall_s:
            rep.status, rep.finding = "failed", f"wall-time cap {max_wall_s} s reached at t = {P.time:.4g} s"
            break
    return hist, rep
