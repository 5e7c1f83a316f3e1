"""The FEM-SPH hybrid step on the 3D strip (fidelity ``hybrid3d``): the 3D engine's failed hexahedra
become 3D SPH particles during the run, which the tool and the surviving elements push and which push back.

The 3D form of the 2D hybrid's lockstep (:mod:`solver.hybrid.coupler`). Every engine step n -> n + 1 of
size dt_n (:mod:`solver.fem3d.loop`; capped at the particles' stable step, :meth:`Hybrid3dCoupler.dt_cap`)
is followed by

1. particles   one kick-drift-kick step of the same dt_n from t^n to t^{n+1} (the compiled SPH of
               :mod:`solver.sph3d`, :func:`coupled_step`), with external forces on top of SPH: the tool
               (:func:`solver.fem3d.contact3d.rigid_contact3d` on the particles: the extruded tool where it
               is at t^{n+1}, the same penalty per unit mass k = TOOL_ALPHA / dt0^2 and Coulomb friction as
               on the nodes) and the pair springs against the boundary faces of the surviving elements at
               x^{n+1} (:func:`solver.hybrid.faces3d.particle_faces`); the strip's sides z = z0 and z = z1
               are frictionless walls for them (:mod:`solver.sph3d.walls`, the nodes' symmetry planes),
               their stiffness per unit mass the tool's. The particles' force on the tool joins the engine's
               tool-force record (``state.tool_out``, summed over steps as the nodes' is);
2. coupling    the external forces found at x^{n+1} act on the particles in the half-kicks of dt_n (now)
               and dt_{n+1} (their next step); the springs' reactions R^{n+1} on the face nodes act in
               engine step n + 1 (``state.fext``, booked by the engine as external work), whose central-
               difference update takes them over (dt_n + dt_{n+1}) / 2: the same impulse on both sides,
               found at one configuration, so nodes + particles keep their momentum (the 2D lockstep);
3. conversion  every element the engine deleted in that step (fibre and matrix; the EHM is deleted
               without a particle, as in 2D) becomes one particle with the element's mass (taken off its
               nodes), centre velocity, density m / (J V0) and Cauchy stress F S F^T / J
               (:mod:`solver.sph3d.conversion`). A newborn particle takes no external force in its first
               half-kick (the old particles keep theirs and the nodes their reactions, so the impulse
               stays balanced).

A particle step below DT_COLLAPSE of the engine's initial step (a particle flung at km/s) ends the run
``unstable`` with the particle, its speed and place (the engine guard's ``dt_collapse`` rule for the
particles). Particles farther than ESCAPE_MARGIN workpiece sizes outside the workpiece's initial box are taken out
(their mass and kinetic energy booked as escaped). The face springs keep a particle from entering an
element; one that is inside a living element after its drift anyway (carried in by an element sliding over
it, or born inside a neighbour that had ridden over its element) is put back out in front of the nearest
free face point (inside no living element; a place inside the tool goes onto its surface) with a plastic
impact on that face (:func:`solver.hybrid.faces3d.expel_from_hexes`, the 3D
form of the 2D hybrid's rule); the nodes take the impact's impulse J in the engine's next step as the force
J / ((dt_prev + dt) / 2) its velocity update integrates over. Particles inside living elements are still
counted at every force sample (:meth:`check_inside`).

Energy (:meth:`Hybrid3dCoupler.hybrid_balance`): the engine's residual (whose balance and guard hold the
kinetic energy its nodes gave up at conversion, at the step's velocities as the balance counts them, with
the deleted elements' energy, as the 2D engine holds it as removed) with the reactions' work W_n taken back
out, plus what the particles received (their kinetic energy at birth) and the tool's
work on them, minus what they hold (kinetic, stress work, viscous and artificial-stress dissipation, less
the walls' work, :meth:`solver.sph3d.particles.Particles3D.energies`), the springs' energy E_s now and what
the coupling dissipates by design: the plastic impacts' D_imp = sum (1/2) mu v_n^2 and the springs' energy
of the pairs forgotten (D_c: those of a particle moved out of an element, and the pair memory's jumps,
:mod:`solver.hybrid.faces3d`). The coupling's net work
W_n + W_p + D_imp + D_c + E_s (W_p its work on the particles, booked in the kicks and the impacts) is zero
but for the integration; it is part of the residual and
reported apart (``coupling_net_work``).

Particle spacing dp = max(2 physics.sph_particle_radius_um, the cube root of the median converting
element's volume) (one particle per element, as in 2D); h = physics.sph_smoothing_factor x dp. The 3D
particles take isotropic material rows (:mod:`solver.sph3d.particles`): the fibre's is isotropic with
its axial E1 and nu12 (the elements' own stiffest direction, so the particles' signal-speed step is not
below the fibre elements'), the matrix's its own; both with the scene's stiffness reduction D0.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..contact import contact_stiffness
from ..fem3d import loop as floop
from ..fem3d.contact3d import N_OUT, living_faces, rigid_contact3d
from ..sph import materials as mt, pair_memory
from ..sph3d import conversion as cv
from ..sph3d import loop as sloop
from ..sph3d import particles as pp
from ..sph3d.loop import NAN, OK, _finite, booked_kick, forces
from ..sph3d.particles import E_STEPS, E_TIME
from ..sph3d.walls import plane
from . import faces3d
from .faces3d import expel_from_hexes, grid_for, inside_living, new_pair_memory, particle_faces

#: rows of ``state.tool_out`` in the 2D layout (:data:`solver.fem3d.engine.TOOL_FORCE_ROWS`)
TOOL_FORCE_ROWS = np.array([0, 1, 5, 6, 8, 9, 11, 12])
#: particles beyond this many workpiece sizes outside the workpiece's initial box have left the cut
ESCAPE_MARGIN = 1.0
#: the largest omega dt of a particle on the tool's penalty (the 2D particles' CONTACT_OMEGA_DT)
TOOL_OMEGA_DT = 1.0
#: engine steps per compiled call while there is no particle (nothing couples; fewer Python round trips)
UNCOUPLED_STEPS = 10
#: the particles' stable step below this fraction of the engine's initial step is a collapse (the engine
#: guard's ``dt_collapse`` rule, :mod:`solver.fem3d.guard3d`): the run ends ``unstable``
DT_COLLAPSE = 1e-2


@numba.njit(cache=True)
def _ext_work(v, a, aext, m, half):
    """The work of the part aext of the acceleration a in the half-kick v' = v + half a:
    sum_i m_i aext_i . (v_i + v'_i) half / 2 (the kick's change of kinetic energy splits linearly)."""
    w = 0.0
    for i in range(v.shape[1]):
        s = 0.0
        for c in range(3):
            s += aext[c, i] * (2.0 * v[c, i] + half * a[c, i])
        w += 0.5 * half * m[i] * s
    return w


@numba.njit(cache=True)
def external(x, v, m, a, at, ac, tool, k_tool, mu, ftool, tout, xn, vn, faces, grid, k_c, r_c, d_max, dt, pairs, fnode,
             cout):
    """The particles' external forces at the current configuration: the tool's (into ftool, its totals into
    tout, :func:`solver.fem3d.contact3d.rigid_contact3d`) and the face springs' (their reactions on the
    nodes into fnode, records into cout, the pairs' memory updated, :func:`solver.hybrid.faces3d.particle_faces`),
    as accelerations at, ac (3, np), added to a."""
    if tool.shape[0] > 0:
        rigid_contact3d(x, v, m, tool, 0, k_tool, mu, ftool, tout, dt, a, None, 1)  # friction's trial sees a
    particle_faces(x, v, xn, vn, faces, grid, k_c, r_c, d_max, dt, pairs, ac, fnode, cout)
    for i in range(x.shape[1]):
        im = 1.0 / m[i]
        for c in range(3):
            at[c, i] = ftool[c, i] * im
            ac[c, i] *= im
            a[c, i] += at[c, i] + ac[c, i]


@numba.njit(cache=True)
def coupled_step(x, v, a, av, ar, m, rho, cs, mat, fix, sig, sst, dmg, R, L, B, est, rmin, mats, prm, walls, en, S, order,
                 cell_of, nbr, nfw, nfn, cnt, A, dt, at, ac, tool, k_tool, mu, ftool, tout, xn, faces, grid, k_c, r_c,
                 d_max, pairs, fnode, cout, wext, vn, invm, hexes, reach, tol, zlo, zhi, jn, eout):
    """One kick-drift-kick step of dt (:mod:`solver.sph3d.loop`) with the external accelerations at, ac
    (held in a) of :func:`external`, found again at the end of the drift; their work in the two half-kicks
    into wext[0] (tool) and wext[1] (face springs). After the drift, particles inside a living hexahedron
    (rows of ``hexes``) are put back out with a plastic impact on the face, within zlo <= z <= zhi and
    not inside the tool (:func:`solver.hybrid.faces3d.expel_from_hexes`; the nodes' impulses into jn, its records
    into eout). Returns (status, nbr, nfw, nfn)."""
    half = 0.5 * dt
    wext[0] += _ext_work(v, a, at, m, half)
    wext[1] += _ext_work(v, a, ac, m, half)
    booked_kick(x, v, a, av, ar, m, fix, walls, half, dt, en)
    expel_from_hexes(x, v, m, xn, vn, invm, hexes, faces, grid, reach, k_c, r_c, tol, tool, zlo, zhi, pairs, jn, eout)
    ok, nbr, nfw, nfn = forces(x, v, a, av, ar, m, rho, cs, mat, sig, sst, dmg, R, L, B, est, rmin, mats, prm, walls, S, order,
                               cell_of, nbr, nfw, nfn, cnt, A, dt)
    if not ok:
        return NAN, nbr, nfw, nfn
    external(x, v, m, a, at, ac, tool, k_tool, mu, ftool, tout, xn, vn, faces, grid, k_c, r_c, d_max, dt, pairs, fnode,
             cout)
    wext[0] += _ext_work(v, a, at, m, half)
    wext[1] += _ext_work(v, a, ac, m, half)
    booked_kick(x, v, a, av, ar, m, fix, walls, half, 0.0, en)
    en[E_TIME] += dt
    en[E_STEPS] += 1.0
    if not _finite(x, v):
        return NAN, nbr, nfw, nfn
    return OK, nbr, nfw, nfn


def scene_materials3d(si, mass_scaling: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The 3D particles' isotropic material rows by mesh material (FIBRE, MATRIX, EHM; module docstring)
    and which convert (fibre and matrix; the EHM's row is a placeholder)."""
    p, fi, ma = si.physics, si.fibre, si.matrix
    fibre = mt.isotropic(fi.E1, fi.nu12, fi.rho * mass_scaling, D0=p.sph_damage_fibre, kappa_f=fi.Xt / fi.E1)
    matrix = mt.isotropic(ma.E, ma.nu, ma.rho * mass_scaling, D0=p.sph_damage_matrix, kappa_f=ma.sigma_u / ma.E)
    return mt.table(fibre, matrix, matrix.copy()), np.array([True, True, False])


class Hybrid3dCoupler:
    """The particles of the 3D strip's failed elements and their coupled step (module docstring)."""

    def __init__(self, state, mats: np.ndarray, converts: np.ndarray, prm: np.ndarray, k_c: float, r_c: float,
                 walls: np.ndarray | None = None, box: tuple | None = None, side_z: tuple | None = None):
        """Particles for the 3D engine ``state`` (its rigid tool, if any, acts on them too): SPH material rows
        ``mats`` by engine material, which of those convert, parameters ``prm``
        (:func:`solver.sph3d.particles.make_params`), the face springs' stiffness k_c [N/m] and contact radius
        r_c [m], the particles' walls (n_w, 7), the escape box (lo (3), hi (3)) and the z of planes whose
        faces do not couple (the strip's sides, where the walls are). :meth:`for_strip` builds it for a scene."""
        self.converts = np.asarray(converts, bool)
        self.conv = cv.start(state, mats, prm)
        P = self.conv.particles
        P.walls = np.zeros((0, 7)) if walls is None else np.ascontiguousarray(walls, np.float64)
        # the tool's penalty per unit mass and friction, as on the nodes (solver.fem3d.contact3d.add_tool)
        has_tool = state.tool.shape[0] > 0
        self.k_tool = float(state.tool_par[1]) if has_tool else 0.0
        self.mu = float(state.tool_par[2]) if has_tool else 0.0
        self.k_c, self.r_c = float(k_c), float(r_c)
        hx = state.X0[:, state.hexes]
        edges = np.concatenate([np.linalg.norm(hx[:, :, a] - hx[:, :, b], axis=0)
                                for a, b in ((0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (4, 5), (5, 6), (6, 7))])
        self.edge_min = float(edges.min())
        self.d_max = 0.5 * self.edge_min  # deeper behind a face than half the thinnest element: not pushed
        self.face_cell = max(2.0 * float(np.median(edges)), self.r_c + self.d_max)
        self.side_z = side_z
        self.z_range = (-math.inf, math.inf) if side_z is None else (float(min(side_z)), float(max(side_z)))
        self.box = box
        nn = state.x.shape[1]
        self.dt_start = floop.stable_dt(state)  # the engine's initial step: the particles' collapse is judged by it
        self.react = np.zeros((3, nn))  # the reactions on the face nodes for the next engine step [N]
        self.fnode = np.zeros((3, nn))
        self.at = np.zeros((3, 0))
        self.ac = np.zeros((3, 0))
        self.ftool = np.zeros((3, 0))
        self.tout = np.zeros(N_OUT)
        self.cout = np.zeros(5)
        self.pairs = new_pair_memory(0)  # each particle's contact pairs with the faces (faces3d.PAIR_ROWS)
        self.wext = np.zeros(2)  # work of the tool and of the face springs on the particles [J]
        self.faces = np.zeros((0, 4), np.int64)
        self.live = np.zeros((0, 8), np.int64)  # the living hexahedra
        self._node_masses(state)  # self.invm: the nodes' 1 / mass for the plastic impacts (0: not free)
        self.alive_key = -1
        self.j_pending = np.zeros((3, nn))  # the impacts' impulses the nodes take in the next engine step [N s]
        self.impulses_pending = False  # whether j_pending holds any
        self.eout = np.zeros(7)
        self.grid = np.zeros(7)
        # records
        self.node_work = 0.0  # the reactions' work on the nodes (the engine's external work meanwhile) [J]
        self.removed_ke = 0.0  # the nodes' kinetic energy taken off with the converted mass [J]
        self.received_ke = 0.0  # the particles' kinetic energy at birth [J]
        self.tool_force_sum = np.zeros(len(TOOL_FORCE_ROWS))  # the particles' part of the tool force [N, summed]
        self.max_tool_penetration = 0.0
        self.max_overlap = 0.0
        self.max_contacts = 0
        self.max_behind = 0
        self.max_inside = 0
        self.max_inside_depth = 0.0
        self.n_expelled = 0  # particle steps that ended inside a living element and were put back out
        self.max_expel = 0.0  # the largest such move [m]
        self.n_expel_no_free = 0  # of them, put in front of a point inside another element (none free in reach)
        self.n_expel_no_face = 0  # particle steps that ended inside an element with no face in reach
        self.impact_loss = 0.0  # what their plastic impacts lost [J]
        self.contact_loss = 0.0  # the energy the moves took out of the face springs [J]
        self.n_escaped = 0
        self.escaped_mass = 0.0
        self.escaped_energy = 0.0  # kinetic + stress work they took with them [J]
        self.sph_steps = 0
        self.finding = ""
        self.dp_from = "given"
        self.dt_react = 0.0  # the particles' step whose end found the reactions now in ``react`` [s]

    @classmethod
    def for_strip(cls, si, mesh, state, width: float) -> "Hybrid3dCoupler":
        """The coupler of a cutting scene on the 3D strip (module docstring): materials, spacing, the pair
        springs' k = PAIR_ALPHA m_min / dt0^2 and r_c = min(particle radius, 0.45 x the shortest edge), the
        strip's sides as walls of the tool's stiffness per unit mass, the escape box."""
        num, phys = si.numerics, si.physics
        mats, converts = scene_materials3d(si, float(num.mass_scaling))
        conv_elems = converts[np.asarray(mesh.material)]
        v_med = float(np.median(state.vol0[conv_elems])) if conv_elems.any() else 0.0
        r_p = float(si.sph_particle_radius)
        dp = max(2.0 * r_p, v_med ** (1.0 / 3.0))
        prm = pp.make_params(dp, h_factor=phys.sph_smoothing_factor, alpha=phys.sph_artificial_viscosity_alpha,
                             beta=phys.sph_artificial_viscosity_beta, eps=phys.sph_artificial_stress,
                             cfl=min(0.3, float(num.cfl)))
        X0 = state.X0
        z0, z1 = float(X0[2].min()), float(X0[2].max())
        k_wall = float(state.tool_par[1])
        walls = np.vstack([plane((0, 0, z0), (0, 0, 1), k_wall), plane((0, 0, z1), (0, 0, -1), k_wall)])
        hx = X0[:, state.hexes]
        e_min = float(min(np.linalg.norm(hx[:, :, a] - hx[:, :, b], axis=0).min()
                          for a, b in ((0, 1), (1, 2), (2, 3), (3, 0), (0, 4))))
        k_c = contact_stiffness(float(state.mass[state.mass > 0].min()), floop.stable_dt(state))
        size = float(np.ptp(X0[0]) + np.ptp(X0[1]))
        lo = X0.min(axis=1) - ESCAPE_MARGIN * size
        hi = X0.max(axis=1) + ESCAPE_MARGIN * size
        c = cls(state, mats, converts, prm, k_c, min(r_p, 0.45 * e_min), walls=walls, box=(lo, hi), side_z=(z0, z1))
        c.dp_from = "particle radius" if dp == 2.0 * r_p else "element size"
        return c

    # ------------------------------------------------------------------ the step
    @property
    def particles(self) -> pp.Particles3D:
        return self.conv.particles

    def nbytes(self) -> int:
        P = self.particles
        own = sum(a.nbytes for a in (self.react, self.fnode, self.at, self.ac, self.ftool))
        return int(own + sum(getattr(P, k).nbytes for k in ("x", "v", "a", "m", "rho", "sig", "L", "B")))

    def _collapse_finding(self, state, dt_p: float) -> dict:
        """The diagnosis of a collapsed particle step: the particle that sets it (the largest c + |v|), its
        speed and position, when."""
        P = self.particles
        speed = np.sqrt(np.sum(P.v * P.v, axis=0))
        i = int(np.argmax(P.cs + speed))
        pos = [float(c) for c in P.x[:, i]]
        return {"check": "dt_collapse", "time_s": state.time, "step": state.steps, "dt_s": dt_p,
                "what": (f"the SPH particles' stable step fell to {dt_p:.3g} s, below {DT_COLLAPSE:g} of the initial "
                         f"step {self.dt_start:.3g} s: particle {i} at {speed[i]:.3g} m/s (sound speed "
                         f"{float(P.cs[i]):.3g} m/s)"),
                "where": {"particle": i, "position_m": pos}, "when": {"time_s": state.time, "step": state.steps},
                "change": "lower numerics.cfl or raise physics.sph_particle_radius_um"}

    def dt_cap(self) -> float:
        """The particles' stable step (signal speed, walls) and omega dt <= 1 on the tool's penalty (inf
        without particles)."""
        P = self.particles
        if P.n == 0:
            return math.inf
        dt = sloop.stable_dt(P)
        return min(dt, TOOL_OMEGA_DT / math.sqrt(self.k_tool)) if self.k_tool > 0 else dt

    def _faces(self, state) -> np.ndarray:
        """The boundary faces of the living elements without those on the strip's sides (the particles'
        walls are there), rebuilt with the living elements when elements died (the nodes' masses change only
        at conversion, :meth:`convert`)."""
        key = int(state.alive.sum())
        if key != self.alive_key:
            self.alive_key = key
            self.live = np.ascontiguousarray(state.hexes[np.flatnonzero(state.alive)], dtype=np.int64)
            f = living_faces(state, tuple(self.side_z) if self.side_z is not None else ())
            self.faces = np.ascontiguousarray(f[:, :4], dtype=np.int64)
        return self.faces

    def _node_masses(self, state) -> None:
        """The nodes' 1 / M for the plastic impacts: 1 / meff, 0 for a node with no mass or fixed in every
        direction; a node on a symmetry side (fixed normal to it) keeps its mass: the faces the particles
        meet there stand normal to the side, so the impulse has no part along the fixed direction. A tied
        node moves with its master (its forces act there)."""
        meff = state.meff
        inv = np.divide(1.0, meff, out=np.zeros_like(meff), where=meff > 0)
        inv[np.all(state.fix != 0, axis=0)] = 0.0
        if state.tie_s.size:
            inv[state.tie_s] = inv[state.tie_m]
        self.invm = inv

    def _buffers(self):
        n = self.particles.n
        if self.at.shape[1] != n:
            pad = n - self.at.shape[1]
            self.at = np.ascontiguousarray(np.hstack([self.at, np.zeros((3, pad))]))
            self.ac = np.ascontiguousarray(np.hstack([self.ac, np.zeros((3, pad))]))
            self.ftool = np.zeros((3, n))
            self.pairs = np.ascontiguousarray(np.hstack([self.pairs, new_pair_memory(pad)]))

    def advance(self, state, t_stop: float, n_steps: int, after_deletion=None):
        """Up to n_steps engine steps (:func:`solver.fem3d.loop.advance`) in lockstep with the particles
        (module docstring): each of the engine's stable size capped at the particles' (:meth:`dt_cap`), the
        steps to t_stop shortened evenly to land on it; the reactions found at the end of the particles'
        last step act on the nodes in the engine's next (``state.fext``; their work, the engine's external
        work meanwhile, is booked as W_n). ``after_deletion()`` runs after a step that deleted elements,
        before they convert. Returns the engine's last StepRecord with ``steps`` and ``deleted`` of the
        whole call (status ``unstable`` also when the particles' step failed)."""
        done = 0
        deleted = 0
        rec = None
        while done < n_steps and state.time < t_stop * (1 - 1e-12):
            dt_p = self.dt_cap()
            if dt_p < DT_COLLAPSE * self.dt_start:
                rec = floop.advance(state, 0, dt=floop.stable_dt(state))
                rec.status, rec.finding = "unstable", self._collapse_finding(state, dt_p)
                break
            dt = min(floop.stable_dt(state), dt_p)
            k = max(1, int(math.ceil((t_stop - state.time) / dt - 1e-9)))
            dt = (t_stop - state.time) / k
            pending = self.impulses_pending
            n = 1 if self.particles.n or pending else min(UNCOUPLED_STEPS, k, n_steps - done)
            state.fext[:] = self.react
            if pending:  # the impacts' impulses J as the forces J / ((dt_prev + dt) / 2) of one step
                state.fext += self.j_pending / (0.5 * (float(state.scal[floop.S_DTPREV]) + dt))
            w0 = float(state.en[floop.E_EXT])
            hg0 = float(state.scal[floop.S_HGRUN])
            rec = floop.advance(state, n, dt=dt)
            self.node_work += float(state.en[floop.E_EXT]) - w0
            if pending and rec.steps:
                self.j_pending[:] = 0.0
                self.impulses_pending = False
            if n < floop.GUARD_EVERY and state.scal[floop.S_HGRUN] > hg0:
                # the guard scans at a call's last step and counts GUARD_EVERY steps of hourglassing per
                # scan; with calls of one step it would fire GUARD_EVERY times too early: count the steps
                state.scal[floop.S_HGRUN] = hg0 + rec.steps
            done += rec.steps
            deleted += rec.deleted
            if rec.status != "ok" or rec.steps == 0:
                break
            status = self.step(state, dt)
            if status != "ok":
                rec.status = "unstable"
                rec.finding = {"check": "sph", "what": f"SPH particles: {status} at t = {state.time:.4g} s",
                               "time_s": state.time, "step": state.steps,
                               "change": "lower numerics.cfl or raise physics.sph_particle_radius_um"}
                break
            if rec.deleted:
                if after_deletion is not None:
                    after_deletion()
                self.convert(state)
        if rec is None:
            rec = floop.advance(state, 0, dt=floop.stable_dt(state))
        rec.deleted = deleted
        rec.steps = done
        return rec

    def step(self, state, dt: float) -> str:
        """The particles' step of dt after the engine's (module docstring, 1 and 2): their force on the
        tool into the engine's record, the reactions for the engine's next step into ``react``. Returns the
        particles' status ("ok" or what went wrong)."""
        P = self.particles
        if P.n == 0:
            self.react[:] = 0.0
            return "ok"
        self._buffers()
        if not P.forces_valid:
            self._prime()
        faces = self._faces(state)
        self.grid = grid_for(P.x, self.face_cell, self.face_cell)
        s = sloop._buffers(P)

        def call():
            return coupled_step(
                *sloop._args(P), float(dt), self.at, self.ac, state.tool, self.k_tool, self.mu, self.ftool, self.tout,
                state.x, faces, self.grid, self.k_c, self.r_c, self.d_max, self.pairs, self.fnode, self.cout, self.wext,
                state.v, self.invm, self.live, self.face_cell, 1e-3 * self.edge_min, *self.z_range, self.j_pending,
                self.eout)

        status, s["nbr"], s["nfw"], s["nfn"] = P.threads.run(call, steps_of=lambda r: 1)
        self.sph_steps += 1
        self._book_expelled()
        self.contact_loss += float(self.cout[4])  # the pair memory's jumps (faces3d.particle_faces)
        if status != OK:
            self.finding = sloop.STATUS_TEXT[int(status)]
            return self.finding
        self.react[:] = self.fnode
        self.dt_react = float(dt)
        f = self.tout[TOOL_FORCE_ROWS]
        state.tool_out[TOOL_FORCE_ROWS] += f
        self.tool_force_sum += f
        self.max_tool_penetration = max(self.max_tool_penetration, float(self.tout[3]))
        self.max_overlap = max(self.max_overlap, float(self.cout[2]))
        self.max_contacts = max(self.max_contacts, int(self.cout[1]))
        self.max_behind = max(self.max_behind, int(self.cout[3]))
        self._escape()
        return "ok"

    def _book_expelled(self) -> None:
        """The records of the particles put back out of living elements in the last step."""
        o = self.eout
        if o[0] or o[4]:
            self.n_expelled += int(o[0])
            self.max_expel = max(self.max_expel, float(o[1]))
            self.wext[1] += o[2]  # the impulses' work on the particles is the coupling's
            self.n_expel_no_free += int(o[3])
            self.n_expel_no_face += int(o[4])
            self.impact_loss += float(o[5])
            self.impulses_pending |= bool(o[5] > 0.0)  # an impact (v_n < 0) gave the nodes an impulse
            self.contact_loss += float(o[6])
            o[:] = 0.0

    def _prime(self) -> None:
        """The SPH accelerations of the current state (after particles were added or taken out), the
        external ones each particle already had (at, ac: zero for a newborn) added back."""
        P = self.particles
        sloop.prime(P)
        P.a += self.at + self.ac

    def convert(self, state) -> int:
        """Particles of the converting elements the engine deleted (module docstring, 3); returns how many."""
        dead = np.flatnonzero((state.alive == 0) & ~self.conv.converted & self.converts[state.mat])
        if dead.size == 0:
            return 0
        ke = self._node_ke(state, dead)
        self.removed_ke += ke
        state.en[floop.E_DEL] += ke  # it left the engine with the elements' mass (module docstring)
        P = self.particles
        n0 = P.n
        new = self.conv.convert(state, dead)
        self._node_masses(state)  # the converted elements' mass went with them
        self.received_ke += 0.5 * float(np.sum(P.m[new] * np.sum(P.v[:, new] ** 2, axis=0)))
        self._buffers()
        self._prime()
        return P.n - n0

    @staticmethod
    def _node_ke(state, elems: np.ndarray) -> float:
        """The kinetic energy the nodes give up with the elements' mass: sum over their nodes of
        (1/2) (m_e / 8) |v^n|^2, v^n the step's velocity as the engine's balance has it
        (:func:`solver.fem3d.loop.energies`: v^{n+1/2} - dt/2 f / m on the free dofs)."""
        q = 0.125 * state.rho[state.mat[elems]] * state.vol0[elems]
        nodes = state.hexes[elems]  # (k, 8)
        dt = float(state.scal[floop.S_DTPREV])
        v = state.v[:, nodes]
        meff = state.meff[nodes]
        free = (state.fix[:, nodes] == 0) & (meff > 0)[None] & (state.slave[nodes] == 0)[None]
        acc = np.divide(state.f[:, nodes], meff[None], out=np.zeros_like(v), where=meff[None] > 0)
        v = np.where(free, v - 0.5 * dt * acc, v)
        return float(0.5 * np.sum(q[:, None] * np.sum(v * v, axis=0)))

    def _escape(self) -> None:
        """Take out particles beyond the escape box (module docstring)."""
        P = self.particles
        if self.box is None:
            return
        lo, hi = self.box
        out = np.any((P.x < lo[:, None]) | (P.x > hi[:, None]), axis=0)
        if not out.any():
            return
        keep = ~out
        self.n_escaped += int(out.sum())
        self.escaped_mass += float(P.m[out].sum())
        self.escaped_energy += float(0.5 * np.sum(P.m[out] * np.sum(P.v[:, out] ** 2, axis=0)) + P.est[out].sum())
        for name in pp.PER_PARTICLE:
            setattr(P, name, np.ascontiguousarray(getattr(P, name)[..., keep]))
        self.conv.particle_elem = self.conv.particle_elem[keep]
        # the reactions the escaped particles' springs left on the nodes stay booked (they already took
        # their half of the impulse); their external accelerations go with them
        self.at = np.ascontiguousarray(self.at[:, keep])
        self.ac = np.ascontiguousarray(self.ac[:, keep])
        self.ftool = np.zeros((3, P.n))
        # their springs with them (far from every face by now)
        self.contact_loss += pair_memory.spring_energy(self.pairs[:, out], self.k_c, faces3d.STRIDE)
        self.pairs = np.ascontiguousarray(self.pairs[:, keep])
        P.scratch.clear()
        P.forces_valid = False
        if P.n:
            self._prime()

    # ------------------------------------------------------------------ reporting
    def check_inside(self, state) -> int:
        """Active particles inside a living element now (:func:`solver.hybrid.faces3d.inside_living`); the
        largest count and depth seen are kept."""
        P = self.particles
        if P.n == 0:
            return 0
        live = state.hexes[state.alive != 0]
        depth = np.zeros(P.n)
        grid = grid_for(P.x, self.face_cell, self.face_cell)
        n_in = int(inside_living(P.x, state.x, np.ascontiguousarray(live), grid, 1e-3 * self.edge_min, depth))
        self.max_inside = max(self.max_inside, n_in)
        self.max_inside_depth = max(self.max_inside_depth, float(depth.max()))
        return n_in

    def spring_energy(self) -> float:
        return float(self.cout[0])

    def energy_terms(self, state) -> dict:
        """The particles' energies and the coupling's records [J] (module docstring)."""
        e = self.particles.energies()
        return {"sph_kinetic": e["kinetic"], "sph_internal": e["internal"], "sph_viscous": e["viscous"],
                "sph_artificial_stress": e["artificial_stress"], "sph_walls_work": e["walls_work"],
                "sph_total": e["total"], "sph_escaped": self.escaped_energy, "sph_kinetic_received": self.received_ke,
                "conversion_removed_kinetic": self.removed_ke, "conversion_loss": self.conv.e_conversion,
                "sph_tool_work": float(self.wext[0]), "sph_coupling_work": float(self.wext[1]),
                "coupling_node_work": self.node_work_now(state), "coupling_spring": self.spring_energy(),
                "coupling_impact_loss": self.impact_loss, "coupling_contact_loss": self.contact_loss,
                "coupling_net_work": self.coupling_net_work(state)}

    def node_work_now(self, state) -> float:
        """W_n [J] to the current configuration x^{n+1}: what the engine booked (to x^n: it books a step's
        external work at the next step) and the last step's, (R^n + R^{n+1}) / 2 . v^{n+1/2} dt_n."""
        dt = float(state.scal[floop.S_DTPREV])
        w = self.node_work + float(np.sum(0.5 * (state.fextp + self.react) * state.v)) * dt
        # pending impulses J act as J / ((dt + dt_next) / 2) over the next step: about J v / 2 to x^{n+1}
        return w + 0.5 * float(np.sum(self.j_pending * state.v))

    def coupling_net_work(self, state) -> float:
        """W_n + W_p + D_imp + D_c + E_s [J]: zero but for the integration."""
        return (self.node_work_now(state) + float(self.wext[1]) + self.impact_loss + self.contact_loss
                + self.spring_energy())

    def hybrid_balance(self, state, fem: dict) -> tuple[float, float]:
        """(residual [J], energy error) of engine and particles as one body (module docstring):

            residual = engine residual - W_n + received + W_tool,p - (particles' total + escaped)
                       - D_imp - D_c - E_s

        and the error is |residual| over the larger of the inputs (the tool's work on nodes and particles,
        the initial energy) and what the body holds."""
        t = self.energy_terms(state)
        e_sph = t["sph_total"] + t["sph_escaped"]
        # the engine's residual counts the reactions' work to x^n (self.node_work): take that out
        res = (fem.get("residual", math.nan) - self.node_work + self.received_ke + t["sph_tool_work"]
               - e_sph - self.impact_loss - self.contact_loss - t["coupling_spring"])
        inputs = abs(fem.get("external", 0.0) - self.node_work) + abs(fem.get("initial", 0.0)) + abs(t["sph_tool_work"])
        stored = (fem.get("internal", 0.0) + fem.get("kinetic", 0.0) + fem.get("hourglass", 0.0) + fem.get("deleted", 0.0)
                  + e_sph)
        return res, abs(res) / max(inputs, stored, 1e-300)

    def impulse_in_flight(self) -> np.ndarray:
        """The momentum [N s] (3) the nodes are still owed: the particles took dt/2 of the forces whose
        reactions ``react`` act on the nodes in the engine's next step. Nodes (at their half-step
        velocities) + particles + this is conserved by the coupling (module docstring, 2); with the impacts'
        impulses the nodes have not taken yet."""
        return 0.5 * self.dt_react * self.react.sum(axis=1) + self.j_pending.sum(axis=1)

    def mass_books(self, state) -> dict:
        """Mass [kg] of the nodes, the particles and the escaped particles (their sum is conserved)."""
        return {"nodes": float(state.mass.sum()), "particles": float(self.particles.m.sum()), "escaped": self.escaped_mass}

    def metrics(self, state, width: float) -> dict:
        P = self.particles
        e = P.energies()
        per = 1.0 / width
        return {"n_particles": P.n, "n_converted_elements": int(self.conv.converted.sum()),
                "n_converted_crushed": self.conv.n_crushed, "sph_steps": self.sph_steps,
                "sph_kinetic_energy_J_per_m": e["kinetic"] * per, "sph_internal_energy_J_per_m": e["internal"] * per,
                "sph_viscous_energy_J_per_m": e["viscous"] * per,
                "sph_artificial_stress_energy_J_per_m": e["artificial_stress"] * per,
                "conversion_kinetic_energy_loss_J_per_m": self.conv.e_conversion * per,
                "sph_tool_work_J_per_m": float(self.wext[0]) * per,
                "coupling_work_on_particles_J_per_m": float(self.wext[1]) * per,
                "coupling_work_on_nodes_J_per_m": self.node_work_now(state) * per,
                "coupling_spring_energy_J_per_m": self.spring_energy() * per,
                "coupling_net_work_J_per_m": self.coupling_net_work(state) * per,
                "coupling_impact_loss_J_per_m": self.impact_loss * per,
                "coupling_contact_state_loss_J_per_m": self.contact_loss * per,
                "sph_max_overlap_with_faces_um": self.max_overlap * 1e6,
                "sph_in_contact_with_faces_max": self.max_contacts,
                "sph_behind_a_face_max": self.max_behind,
                "sph_particles_inside_elements_max": self.max_inside,
                "sph_max_depth_inside_elements_um": self.max_inside_depth * 1e6,
                "sph_expelled_from_elements": self.n_expelled, "sph_max_expel_depth_um": self.max_expel * 1e6,
                "sph_expelled_onto_another_element": self.n_expel_no_free,
                "sph_inside_with_no_boundary_in_reach": self.n_expel_no_face,
                "sph_max_tool_penetration_um": self.max_tool_penetration * 1e6,
                "sph_escaped_particles": self.n_escaped,
                "sph_contact_radius_um": self.r_c * 1e6, "sph_smoothing_length_um": P.h * 1e6,
                "sph_spacing_um": float(P.prm[pp.P_DP]) * 1e6, "sph_spacing_from": self.dp_from}

    def frame(self) -> dict:
        """Positions (n, 3) as the nodes' ``positions``, material, tensile damage and acting Cauchy stress
        (xx, yy, zz, xy, yz, zx) of the particles."""
        P = self.particles
        return {"particles_positions": np.ascontiguousarray(P.x.T), "particles_material": P.mat.copy(),
                "particles_damage": P.dmg[1].copy(),
                "particles_stress": P.sig.T.astype(np.float32)}
