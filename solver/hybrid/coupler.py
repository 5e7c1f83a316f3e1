"""The FEM-SPH hybrid step of the cutting scene (the paper's contribution, docs/model.md).

The engine (:mod:`solver.fem`) applies the tool and the fragment contact at every one of its steps; the
particles and the coupling run between its steps. In **lockstep** (``numerics.coupling_sync_steps`` = 1,
the default) every engine step n -> n + 1 of size dt_n is followed by

1. particles   one SPH step of the same dt_n from t^n to t^{n+1} (the engine's step is capped at the
               particles' stable step: the signal-speed step and 1 / omega of the tool penalty's
               oscillator), the tool acting on them with the same exact geometry, penalty per unit mass
               and friction as on the nodes (:func:`solver.contact.tool_contact`, in the compiled loop);
               their tool force joins the engine's tool force record;
2. coupling    at the end of that step, particles against the boundary edges of the surviving elements
               (intact interface faces included) where engine step n put them, x^{n+1}: a particle
               in front of an edge and closer than r_c is pushed out by the node-to-segment penalty, its
               separation speed limited to the tool speed (:mod:`solver.sph.coupling`). The force
               reaches the particle in the half-kicks of dt_n (now) and dt_{n+1} (its next step); its
               reaction R^{n+1} acts on the edge nodes in engine step n + 1 (state.fext, booked as
               external work), whose central-difference velocity update takes it over (dt_n + dt_{n+1})
               / 2: both sides take the same impulse, found at the same configuration, so the pair's
               net work W_nodes + W_particles (``coupling_net_work_J_per_m``, part of the hybrid's
               energy error) is the integration's, not a lag's. After the drift a particle found
               inside a living element is put out of all of them, r_c in front of the nearest boundary
               edge, its velocity into that edge cancelled (a plastic impact whose impulse the edge's
               nodes take in the next engine step; :func:`solver.sph.coupling.expel_from_elements`):
               particles never stay inside an intact element. Particle-particle interaction across
               fragments is SPH;
3. conversion  every element the engine deleted gives its dormant particle the element's mass (off its
               nodes), centre velocity, Cauchy stress sigma = F S F^T / J (the engine stores 2nd
               Piola-Kirchhoff S) and rotated material axis (:mod:`solver.sph.conversion`); a particle
               whose element had ridden over a living neighbour before it failed, so that its centre
               lies inside that neighbour, is put out of every living element, r_c in front of the
               nearest boundary edge (:meth:`HybridCoupler._place_newborn`).

The lockstep runs in compiled code (:func:`solver.hybrid.lockstep.lockstep_steps`): one call takes up to
a chunk's steps, each the engine's compiled step (:func:`solver.fem.loop._chunk_impl`), the particles'
(:func:`solver.sph.loop.advance`) and the edges' binning, with the same arithmetic as the Python step
(:meth:`HybridCoupler._after_engine`), which still takes the steps in which an element died (conversion,
a new boundary) or a particle escaped, those with plastic impacts' impulses pending and the first step
after a conversion. The living elements' cell list that finds the particles inside an element is a
Verlet list (:meth:`HybridCoupler._element_bins`): built with a skin and kept until an element dies or a
node has moved half of it, it gives the answers a list built at every step would.

With more sync steps (:meth:`HybridCoupler._subcycled`) the engine runs that many steps, then conversion,
then the particles catch up in steps of their own (at least half their stable step: when less is due
they wait) against the edges frozen where the engine left them, and the reactions summed over those
steps act on the nodes over the engine's next sub-chunk: cheaper per engine step, but the nodes take the
reactions late, at their velocities of then, and the pair makes energy (measured: 43 % of the tool's
work in the full D = 0.1 cut at 5 steps; docs/validation.md).

Particle spacing dp (and h = physics.sph_smoothing_factor x dp) is the paper's particle diameter
2 x physics.sph_particle_radius_um, but at least the square root of the median converting element's
area: there is one particle per element, so with elements coarser than the particles (the -quick
scenes) a smoothing length from the radius alone would leave every particle without neighbours.
"""

from __future__ import annotations

import math
import time

import numpy as np

import numba

from .. import fem as fem_package
from ..contact import _build_cells, boundary_edges
from ..fem import loop as fem_loop
from ..sph import conversion as cv
from ..sph import loop
from ..sph import particles as pp
from ..sph.coupling import bin_elements, depth_inside, expel_from_elements, spring_energy
from ..sph.particles import ACTIVE, M, VX, VY, X, Y
from ..threads import ThreadChoice
from ..tool import out_of_tool
from .lockstep import (A_BIN_BUILDS, A_CONTACT_LOSS, A_COUPLE_WORK, A_DT_REACT, A_IMPACT_LOSS, A_MAX_EXPEL,
                       A_MAX_OVERLAP, A_MAX_TOOL_PEN, A_N_EXPELLED, A_NO_EDGE, A_NO_FREE, A_NODE_WORK, A_P_STEPS,
                       A_P_TIME, A_SPH_STEPS, A_TOOL_WORK, ACC_SIZE, ENGINE_STOP, HANDOFF, PENDING, SPH_STOP,
                       element_verlet_list, lockstep_steps)

# engine energy accumulators (solver.fem.state)
from ..fem.state import E_EXT, E_REMOVED, P_CFL, P_MMIN, S_DTCRIT, S_DTPREV, TOOL_FORCE_ROWS

#: particles farther than this many workpiece sizes outside the workpiece's initial box have left
#: the cut (thrown-off debris): they are taken out of the simulation, their kinetic energy booked
#: as escaped (the outflow boundary of SPH codes); otherwise a few far-flung particles would blow
#: up the neighbour grid's bounding box
ESCAPE_MARGIN = 1.0
#: the skin of the living elements' cell list around the particles, in particle spacings
#: (:meth:`HybridCoupler._element_bins`): it is rebuilt once a node has moved half of it
BIN_SKIN = 0.5
#: an empty cell list of elements for the compiled loop's first build (:func:`solver.sph.coupling.bin_elements`)
_NO_BINS = (np.zeros(2, np.int64), np.zeros(1, np.int64), np.array([0.0, 0.0, 1.0, 1.0, 1.0]))


def cauchy_from_pk2(state, elems: np.ndarray):
    """Cauchy stress sigma = F S F^T / J at the centre of the given quads (S: the engine's 2nd
    Piola-Kirchhoff stress), as (sxx, syy, sxy) arrays of len(elems)."""
    q = state.quads[elems]
    dxi = np.array([-0.25, 0.25, 0.25, -0.25])
    det_ = np.array([-0.25, -0.25, 0.25, 0.25])
    X0, Y0, x, y = state.X0[q], state.Y0[q], state.x[q], state.y[q]
    J0 = np.stack([np.stack([X0 @ dxi, X0 @ det_], -1), np.stack([Y0 @ dxi, Y0 @ det_], -1)], -2)
    J = np.stack([np.stack([x @ dxi, x @ det_], -1), np.stack([y @ dxi, y @ det_], -1)], -2)
    Fd = J @ np.linalg.inv(J0)
    S = np.zeros((len(elems), 2, 2))
    S[:, 0, 0] = state.stress[elems, 0]
    S[:, 1, 1] = state.stress[elems, 1]
    S[:, 0, 1] = S[:, 1, 0] = state.stress[elems, 2]
    detF = np.linalg.det(Fd)
    sig = Fd @ S @ np.transpose(Fd, (0, 2, 1)) / detF[:, None, None]
    return sig[:, 0, 0].copy(), sig[:, 1, 1].copy(), sig[:, 0, 1].copy()


class HybridCoupler:
    """Dormant particles of a cutting scene and the coupled sub-chunk step (module docstring)."""

    def __init__(self, mesh, si, state, k_tool: float, k_pair: float, mu: float):
        from ..fem.materials import RHO

        num, phys = si.numerics, si.physics
        ms = float(num.mass_scaling)
        mats, converts = cv.scene_materials(si, ms)
        # particle spacing: the paper's particle diameter 2 r_p, but never below the size of the converting
        # elements (one particle per element: with elements larger than 2 r_p, a smoothing length from r_p
        # alone would leave the particles without neighbours)
        conv_elems = np.isin(np.asarray(mesh.material), np.flatnonzero(converts))
        a_med = float(np.median(state.area0[conv_elems])) if conv_elems.any() else 0.0
        dp = max(2.0 * float(si.sph_particle_radius), math.sqrt(a_med))
        self.dp_from = "particle radius" if dp == 2.0 * float(si.sph_particle_radius) else "element size"
        prm = pp.make_params(dp, h_factor=phys.sph_smoothing_factor, alpha=phys.sph_artificial_viscosity_alpha,
                             beta=phys.sph_artificial_viscosity_beta, eps=phys.sph_artificial_stress,
                             cfl=min(0.3, float(num.cfl)))
        self.conv = cv.build_dormant(mesh.material, converts, mats, prm)
        self.elem_mass = state.props[state.mat, RHO] * state.area0
        self.k_pen = float(k_tool)  # the tool's penalty on the lightest node [N/m per m] (contact.TOOL_ALPHA)
        # per unit mass, as on every node (solver.contact.tool_contact with by_mass): the same contact
        # period for every particle; their step is held to resolve it (loop.stable_dt)
        self.k_tool = self.k_pen / float(state.params[P_MMIN])
        self.mu = float(mu)
        # the particle-edge springs: a pair of deformable bodies (contact.PAIR_ALPHA), applied at every
        # particle step (steps no longer than the engine's)
        self.k_couple = float(k_pair)
        # the penalty's separation-speed limit: the tool's speed (solver.sph.coupling)
        self.v_sep = float(np.hypot(state.tool[2], state.tool[3]))
        # engine steps per particle-element exchange: 1 is the lockstep (:meth:`_lockstep`), more the
        # cheaper sub-chunked coupling whose nodes take the reactions late (:meth:`_subcycled`)
        self.sync_every = int(num.coupling_sync_steps)
        state.fext = np.zeros((4, state.x.size))  # the particles' reactions on the edge nodes
        # the reaction impulses not yet handed to the nodes [N s/m] and the engine time left to hand them
        # over in (:meth:`advance`)
        self.j_pending = np.zeros((2, state.x.size))
        # lockstep: the reaction forces on the edge nodes at the current configuration [N/m]
        self.react = np.zeros((2, state.x.size))
        self.dt_react = 0.0  # the particle step at whose end they were found [s]
        self.h_pending = 0.0
        self.fext_bytes = int(state.fext.nbytes)
        self.edge_key = None
        self._fn = None
        self.threads = ThreadChoice()  # of the compiled lockstep loop's calls
        # the living elements' Verlet list (:meth:`_element_bins`): its cell list, the alive count and the
        # box it was built for, the node positions at the build
        self._lb_bins = None
        self._lb_key = None
        self._lb_box = np.zeros(4)
        self._lb_x = np.zeros(state.x.size)
        self._lb_y = np.zeros(state.x.size)
        self.n_bin_builds = 0
        # the compiled lockstep loop (:mod:`solver.hybrid.lockstep`): its records and scratch
        self._acc = np.zeros(ACC_SIZE)
        self._codes = np.zeros(3, np.int64)
        self._tool_sph = np.zeros(np.asarray(state.tool).size)
        self._tout = np.zeros(10)
        self._sout = np.zeros(5)
        self._eout = np.zeros(4)
        self._expelled = np.zeros(7)
        self.n_compiled_calls = 0
        self.edges = np.zeros((0, 3), np.int32)
        self.live = np.zeros(0, np.int64)
        edge_min = float(np.min(np.hypot(mesh.x[mesh.quads] - mesh.x[np.roll(mesh.quads, -1, 1)],
                                         mesh.y[mesh.quads] - mesh.y[np.roll(mesh.quads, -1, 1)])))
        self.r_c = min(float(si.sph_particle_radius), 0.45 * edge_min)
        self.edge_max = float(np.max(np.hypot(mesh.x[mesh.quads] - mesh.x[np.roll(mesh.quads, -1, 1)],
                                              mesh.y[mesh.quads] - mesh.y[np.roll(mesh.quads, -1, 1)])))
        self.n_alive_total = int(state.alive.size)
        self.max_overlap = 0.0
        self.max_inside = 0  # most active particles found inside a living element at a force sample
        self.max_inside_depth = 0.0  # and the deepest [m]
        self.n_born_moved = 0  # newborn particles moved out of a living element (:meth:`_place_newborn`)
        self.n_born_kept = 0  # newborn particles still inside a living element after that (none free in reach)
        self.n_born_in_tool = 0  # newborn particles put from inside the tool onto its surface (:meth:`_place_newborn`)
        self.max_birth_shift = 0.0  # [m]
        self.n_expelled = 0  # particle steps that ended inside a living element and were put back out
        self.max_expel = 0.0  # the largest such move [m]
        self.n_expel_no_free = 0  # of them, put on a foot inside another element (none free in reach)
        self.n_expel_no_edge = 0  # particle steps that ended inside an element with no boundary edge in reach
        self.max_tool_penetration = 0.0  # deepest particle in the tool [m]
        x0, x1, y0, y1 = float(mesh.x.min()), float(mesh.x.max()), float(mesh.y.min()), float(mesh.y.max())
        pad = ESCAPE_MARGIN * max(x1 - x0, y1 - y0)
        self.box = (x0 - pad, x1 + pad, y0 - pad, y1 + pad)
        self.n_escaped = 0
        self.escaped_ke = 0.0  # kinetic energy the escaped particles took with them [J/m]
        self.tool_work = 0.0
        self.couple_work = 0.0  # work of the particle-edge coupling forces on the particles [J/m]
        # the engine's external work while the coupling runs: the reactions' work on the nodes (the
        # cutting scene's supports are fixed and do none) [J/m]
        self.node_work = 0.0
        self.impact_loss = 0.0  # what the plastic impacts of particles put back out of elements lost [J/m]
        # what the particle-edge contact springs dissipate by design: the force the separation-speed limit
        # holds back, along the path, and the energy of compressed pairs leaving reach or forgotten, less
        # what new pairs' carried compression added [J/m] (solver.sph.coupling)
        self.contact_loss = 0.0
        # the particles' part of the tool force, summed like state.tool_out[TOOL_FORCE_ROWS] (over engine
        # steps; in all and by face of the tool): the caller's force samples split the tool force into what
        # the particles and the nodes carry
        self.tool_force_sum = np.zeros(TOOL_FORCE_ROWS.size)
        self.sph_steps = 0
        self.t_sph = None  # the particles' clock (None while no particle is active)
        self.status, self.finding = "ok", ""

    @property
    def particles(self) -> pp.Particles | None:
        return None if self.conv is None else self.conv.particles

    def nbytes(self) -> int:
        """The particles' arrays, the engine's external-force rows the coupling added (state.fext) and the
        nodes' reaction and impulse buffers."""
        if self.conv is None:
            return 0
        return (self.conv.particles.nbytes() + self.fext_bytes + self.j_pending.nbytes + self.react.nbytes
                + (0 if self._fn is None else self._fn.nbytes))

    # ------------------------------------------------------------------ the coupled step
    def _escape(self, P) -> int:
        """Take out the active particles outside ``self.box`` (see ESCAPE_MARGIN); returns their number."""
        a = P.active_indices()
        if a.size == 0:
            return 0
        x, y = P.F[X, a], P.F[Y, a]
        bx0, bx1, by0, by1 = self.box
        out = a[(x < bx0) | (x > bx1) | (y < by0) | (y > by1)]
        if out.size == 0:
            return 0
        self.escaped_ke += 0.5 * float(np.sum(P.F[M, out] * (P.F[VX, out] ** 2 + P.F[VY, out] ** 2)))
        P.I[ACTIVE, out] = 0
        P.refresh_active()
        P.forces_valid = False
        self.n_escaped += int(out.size)
        return int(out.size)

    def _convert(self, state) -> int:
        C = self.conv
        dead = np.flatnonzero((state.alive == 0) & (C.elem_particle >= 0))  # dead with a dormant particle
        if dead.size == 0:
            return 0
        ne = state.alive.size
        sxx = np.zeros(ne)
        syy = np.zeros(ne)
        sxy = np.zeros(ne)
        sxx[dead], syy[dead], sxy[dead] = cauchy_from_pk2(state, dead)
        ke0 = C.ke_from_nodes
        born = C.elem_particle[dead].copy()
        n = C.convert(state.alive, state.quads, state.X0, state.Y0, state.x, state.y, state.vx, state.vy,
                         state.mass, self.elem_mass, sxx, syy, sxy, state.phi)
        # the engine's balance: the kinetic energy its nodes gave up left with the removed elements
        state.en[E_REMOVED] += C.ke_from_nodes - ke0
        # (a particle is converted once: its contact pair memory is still empty, solver.sph.coupling)
        self._place_newborn(state, born[C.particles.I[ACTIVE, born] == 1])
        return n

    def _place_newborn(self, state, born: np.ndarray) -> None:
        """Move a newborn particle that lies inside a living element out of every living element.

        A particle is born at its element's centre. An interface sheared by microns lets a matrix
        element ride over its fibre before the matrix element fails (docs/validation.md),
        so its centre can lie inside the fibre. It goes to the place r_c in front of the nearest foot of its
        perpendicular on a boundary edge within reach that lies inside no living element
        (:func:`solver.sph.coupling.expel_from_elements`, positions only): mostly onto the fibre's
        interface face, the seam between the fibre and the matrix that slid over it, where the
        matrix's material belongs (r_c in front lies inside that matrix element, so a hair in front: a
        point on a seam touches the element across it, it is not in it). Its mass, velocity and stress do not change, so the mass, momentum and energy balances
        are untouched; its first step cancels a velocity into the edge. Counted, with the largest
        shift (``sph_born_inside_moved``, ``sph_born_inside_max_shift_um``), and those still inside
        an element afterwards (none free in reach, ``sph_born_inside_kept``). The nearest boundary edge
        of the element it was in would not do: it can lie inside another element that has slid over
        the same spot, or be missing for an element with no boundary edge.

        A particle born inside the tool (its element crushed against the tool, its centre past the tool's
        surface) goes onto the surface along the tool's normal (:func:`solver.tool.out_of_tool`, counted in
        ``sph_born_inside_tool``), as a particle put out of an element does: left there, the tool's penalty
        (omega dt = 1) flung it out at the depth over the step, 0.21 um inside at 8 km/s in the full D 0.1
        scene, and the energy it took from nothing stopped the run."""
        if born.size == 0:
            return
        P = self.conv.particles
        ec = self._edge_contact(state)
        if ec is None:
            return
        x0, y0, cell, ncx, ncy = ec.grid[:5]
        rec = np.zeros(7)
        expel_from_elements(P.F, born.astype(np.int64), born.size, ec.edges, ec.quads, ec.x, ec.y, ec.vx, ec.vy,
                            x0, y0, cell, int(ncx), int(ncy), ec.estart, ec.eitems, ec.lgrid, ec.lstart, ec.litems,
                            False, ec.nmass, ec.jxn, ec.jyn, loop.edge_pairs(P), self.k_couple, self.r_c, state.tool,
                            state.has_tool, rec)
        self.n_born_moved += int(rec[0])
        self.max_birth_shift = max(self.max_birth_shift, float(rec[1]))
        self.n_born_kept += int(rec[3] + rec[4])  # left inside an element: no free foot, or no edge in reach
        if state.has_tool:  # born inside the tool (its element crushed against it): onto the tool's surface
            for i in born:
                x, y = out_of_tool(P.F[X, i], P.F[Y, i], state.tool)
                if x != P.F[X, i] or y != P.F[Y, i]:
                    self.n_born_in_tool += 1
                    self.max_birth_shift = max(self.max_birth_shift, math.hypot(x - P.F[X, i], y - P.F[Y, i]))
                    P.F[X, i], P.F[Y, i] = x, y
        P.forces_valid = False

    def _boundary(self, state) -> np.ndarray:
        """Every boundary edge of the living quads, the faces of intact interfaces included
        (:func:`solver.contact.boundary_edges`), rebuilt only when elements died since the last call.
        A particle can reach an intact interface face only through the thin element on its other
        side, and that face then pushes it back (left out, particles crossed a thin matrix element
        into the fibre behind it and stayed there: up to 16 at a time, 1.25 um deep, in the quick
        scenes)."""
        key = int(state.alive.sum())  # elements only ever die: the count identifies the living set
        if key != self.edge_key:
            self.edge_key = key
            self.edges = boundary_edges(state.quads, state.alive)
            self.eitems = np.empty(max(self.edges.shape[0], 1), np.int64)
            self.live = np.flatnonzero(state.alive).astype(np.int64)
        return self.edges

    def _edge_contact(self, state) -> loop.EdgeContact | None:
        """The boundary edges of the surviving elements (:meth:`_boundary`) and the surviving elements,
        binned where the engine left them (None when there are no edges)."""
        e = self._boundary(state)
        if e.shape[0] == 0:
            return None
        nodes = e[:, :2].reshape(-1)
        cell = self.edge_max + self.r_c
        # over the edges, but no farther than the box the particles live in (:meth:`_escape`): a living
        # fragment flying off would otherwise stretch the grid without bound. An edge outside is
        # binned in the nearest rim cell, where a particle near it (also on the rim) still finds it
        bx0, bx1, by0, by1 = self.box
        x0 = max(float(state.x[nodes].min()), bx0) - cell
        y0 = max(float(state.y[nodes].min()), by0) - cell
        ncx = int((min(float(state.x[nodes].max()), bx1) - x0) / cell) + 2
        ncy = int((min(float(state.y[nodes].max()), by1) - y0) / cell) + 2
        estart = np.empty(ncx * ncy + 1, np.int64)
        _build_cells(state.x, state.y, e, x0, y0, cell, ncx, ncy, estart, self.eitems)
        # the separation-speed limit spreads its velocity change over at least the engine's stable step
        # (a step cut short to land on a sample time would make its force m dv / dt huge, and that force
        # acts over the next full step as well)
        dt_lim = float(state.scal[S_DTCRIT]) * float(state.params[P_CFL])
        grid = np.array([x0, y0, cell, ncx, ncy, self.k_couple, self.r_c, self.v_sep, dt_lim])
        P = self.conv.particles
        a = P.active_indices()
        px, py = (P.F[X, a], P.F[Y, a]) if a.size else (state.x[nodes], state.y[nodes])
        # the elements around the particles and around every foot the projection may try: the
        # edges in reach lie in the 3 x 3 edge cells around a particle, two cells at most
        lstart, litems, lgrid = self._element_bins(state, px, py, 2.0 * cell)
        if self._fn is None or self._fn.shape[1] != state.x.size:
            self._fn = np.zeros((4, state.x.size))  # the nodes' reaction forces and impulses, reused
        return loop.EdgeContact(e, state.quads, state.x, state.y, state.vx, state.vy, grid, estart, self.eitems, lgrid,
                                lstart, litems, self._fn[0], self._fn[1], self._fn[2], self._fn[3], nmass=state.mass)

    def _bin_elements(self, state, px: np.ndarray, py: np.ndarray, margin: float):
        """The living elements near the points (px, py), within ``margin`` of their bounding box, in a
        cell list of the particle spacing, or coarser when debris spreads the points so far that it
        would have more than 256 cells a side (:func:`solver.sph.coupling.bin_elements`)."""
        self._boundary(state)  # refreshes self.live
        x0, y0 = float(px.min()) - margin, float(py.min()) - margin
        x1, y1 = float(px.max()) + margin, float(py.max()) + margin
        cell = max(float(self.conv.particles.prm[pp.P_DP]), max(x1 - x0, y1 - y0) / 256.0)
        return bin_elements(state.quads, self.live, state.x, state.y, cell, x0, y0, x1, y1, 0.0)

    def _element_bins(self, state, px: np.ndarray, py: np.ndarray, reach: float):
        """The living elements around the points (px, py), within ``reach`` of their bounding box, as the
        compiled loop keeps them: a Verlet list with a skin of BIN_SKIN x the particle spacing, valid until an
        element dies (:func:`solver.hybrid.lockstep.element_verlet_list`); its answers are those of a list
        built now."""
        self._boundary(state)  # refreshes self.live and self.edge_key
        valid = self._lb_bins is not None and self._lb_key == self.edge_key
        lstart, litems, lgrid = self._lb_bins if valid else _NO_BINS
        lstart, litems, lgrid, built = element_verlet_list(
            state.quads, self.live, state.x, state.y, state.node_active, float(px.min()), float(py.min()),
            float(px.max()), float(py.max()), float(reach), BIN_SKIN * float(self.conv.particles.prm[pp.P_DP]),
            float(self.conv.particles.prm[pp.P_DP]), self._lb_box, self._lb_x, self._lb_y, int(valid), lstart, litems,
            lgrid)
        if built:
            self._lb_key = self.edge_key
            self._lb_bins = (lstart, litems, lgrid)
            self.n_bin_builds += 1
        return self._lb_bins

    def _book(self, ec: loop.EdgeContact | None) -> None:
        """The records of a particle chunk's coupling: the work on the particles, the plastic impacts' loss,
        the particles put back out of elements, the deepest overlap."""
        if ec is None:
            return
        self.couple_work += float(ec.out[2] + ec.expelled[2])
        self.impact_loss += float(ec.expelled[5])
        self.contact_loss += float(ec.out[3] + ec.expelled[6])
        self.n_expelled += int(ec.expelled[0])
        self.max_expel = max(self.max_expel, float(ec.expelled[1]))
        self.n_expel_no_free += int(ec.expelled[3])
        self.n_expel_no_edge += int(ec.expelled[4])
        if ec.out[1] > 0:
            self.max_overlap = max(self.max_overlap, float(ec.out[0]))

    def _pend(self, jx: np.ndarray, jy: np.ndarray, h: float) -> None:
        """Impulses [N s/m] for the edge nodes, handed over by :meth:`_engine` as the forces J / h."""
        if h <= 0 or not (np.any(jx) or np.any(jy)):
            return
        self.j_pending[0] += jx
        self.j_pending[1] += jy
        self.h_pending = max(self.h_pending, h)

    def _engine(self, engine, state, n: int, t_stop: float, dt_max: float | None):
        """n engine steps (fewer at t_stop) with the particles' reactions on the edge nodes (state.fext,
        whose work the engine books as external): the reaction forces ``self.react`` and the pending
        impulses J as the forces J / h_pending. What the steps did not hand over of J (cut short by a
        sample time) or handed over too much waits for the next call, so the nodes get all of it; the
        central difference's velocity update at step k takes f^k over (dt_{k-1} + dt_k) / 2, so over the
        steps the nodes got f (tau + (dt_before - dt_last) / 2). Returns the engine's StepRecord and the
        steps done; state.fext[0:2] keep the forces of this call (every call sets them anew)."""
        pending = self.h_pending > 0.0
        state.fext[0:2] = self.react
        if pending:
            fj = self.j_pending / self.h_pending
            state.fext[0:2] += fj
        w0 = float(state.en[E_EXT])
        dtp0 = float(state.scal[S_DTPREV])
        t0, s0 = state.time, state.steps
        rec = engine(n, t_stop, dt_max)
        self.node_work += float(state.en[E_EXT]) - w0
        k = state.steps - s0
        if pending:
            tau = state.time - t0
            if k > 0:
                self.j_pending -= fj * (tau + 0.5 * (dtp0 - float(state.scal[S_DTPREV])))
            # a remainder with no time left is handed over in the next call, over this one's length
            self.h_pending = self.h_pending - tau if self.h_pending > tau * (1 + 1e-9) else tau
            if not np.any(self.j_pending):
                self.h_pending = 0.0
        return rec, k

    def _particles(self, state, rec, n: int, dt: float, dt_engine: float) -> loop.EdgeContact | None:
        """n particle steps of dt that end at the engine's time, the tool acting where it was then
        (:func:`solver.sph.loop.step_chunk`), the edges where the engine left them; their tool force
        joins the engine's record (state.tool_out[0:2] sums over engine steps of mean length
        ``dt_engine``). On a particle instability rec's status becomes ``unstable`` with the finding.
        Returns the edge contact (its reactions and impulses), None without edges."""
        P = self.conv.particles
        h = n * dt
        tool_sph = np.array(state.tool, dtype=np.float64)  # the tool where it was at the particles' time
        tool_sph[0] -= tool_sph[2] * h
        tool_sph[1] -= tool_sph[3] * h
        tout = np.zeros(10)
        ec = self._edge_contact(state)
        r = loop.step_chunk(P, n, dt, tool=tool_sph, k_pen=self.k_tool, mu=self.mu, tool_out=tout, edges=ec,
                            tool_by_mass=True)
        self.sph_steps += r.steps
        self.tool_work += r.tool_work
        self._book(ec)
        if r.status != "ok":
            self._sph_failed(state, rec, r.finding)
            return ec
        scale = dt / dt_engine
        f = tout[TOOL_FORCE_ROWS] * scale
        state.tool_out[TOOL_FORCE_ROWS] += f
        self.tool_force_sum += f
        # the particles' deepest penetration is reported apart from the nodes'
        self.max_tool_penetration = max(self.max_tool_penetration, float(tout[2]))
        state.tool_out[3] += tout[3] * dt
        return ec

    def _sph_failed(self, state, rec, finding: str) -> None:
        """The particles' guard fired (finding: :func:`solver.sph.loop.step_chunk`'s): the run is unstable."""
        self.status, self.finding = "unstable", f"SPH particles: {finding} at t = {state.time:.4g} s"
        rec.status = "unstable"
        rec.finding = {"check": "sph", "what": self.finding, "time_s": state.time, "step": state.steps,
                       "change": "lower numerics.cfl or raise physics.sph_particle_radius_um"}

    def advance(self, fem, state, t_stop: float, chunk_steps: int, engine=None):
        """Up to ``chunk_steps`` engine steps of the coupled body, in lockstep
        (``numerics.coupling_sync_steps`` = 1, :meth:`_lockstep`) or in sub-chunks (:meth:`_subcycled`).
        ``engine(n, t_stop, dt_max) -> StepRecord`` advances the engine by n steps of at most dt_max
        (None: no cap); default ``fem.advance``. Returns the engine's last StepRecord (status ``unstable``
        also when the particles' guard fired)."""
        compiled = engine is None and fem is fem_package
        if engine is None:
            def engine(n, ts, dt_max):
                return fem.advance(state, n, dt_max, k_pen=self.k_pen, mu=self.mu, t_stop=ts)
        if self.sync_every == 1:
            return self._lockstep(engine, state, t_stop, chunk_steps, compiled)
        return self._subcycled(engine, state, t_stop, chunk_steps)

    def _lockstep(self, engine, state, t_stop: float, chunk_steps: int, compiled: bool = False):
        """Engine and particles take the same steps, the coupling forces of one configuration acting on
        both in the same velocity update (module docstring): after engine step n (dt_n, capped at the
        particles' stable step) the particles step from t^n to t^{n+1} with dt_n; their coupling forces at
        the end, found against the edges at x^{n+1}, reach them in the half-kicks of dt_n and dt_{n+1},
        and their reactions R^{n+1} act on the nodes in engine step n+1, whose velocity update takes
        them over (dt_n + dt_{n+1}) / 2: the same impulse, from the same positions. Then conversion.

        With ``compiled`` (the engine is the FEM package's own) the steps run in the compiled loop
        :func:`solver.hybrid.lockstep.lockstep_steps` whenever it can take them (:meth:`_compiled_args`):
        the same steps, one Python call for many; it hands back the rest of a step in which an element
        died or a particle escaped (:meth:`_after_engine`), and the steps with pending impulses run here."""
        P = self.conv.particles
        rec = None
        done = 0
        while done < chunk_steps and state.time < t_stop * (1 - 1e-12):
            args = self._compiled_args(state) if compiled and P.n_act else None
            if args is not None:
                t0 = time.perf_counter()
                code, k, rec = self._run_compiled(state, t_stop, chunk_steps - done, args)
                self.threads.record(args, time.perf_counter() - t0, k)
                done += k
                if code in (ENGINE_STOP, SPH_STOP):
                    break
                if code == PENDING:  # plastic impacts: their impulses
                    self._pend(self._fn[2], self._fn[3], self.dt_react)
                elif code == HANDOFF and not self._after_engine(state, rec):
                    break
                continue
            # with no particle nothing couples: longer engine sub-chunks save Python overhead
            n = 1 if P.n_act else 10
            dt_max = loop.stable_dt(P, self.k_tool) if P.n_act else None
            rec, k = self._engine(engine, state, n, t_stop, dt_max)
            done += k
            if rec.status != "ok" or k == 0:
                break
            if not self._after_engine(state, rec):
                break
        return rec

    def _after_engine(self, state, rec) -> bool:
        """The rest of a lockstep step after the engine's: escapes, the particles' step, their reactions
        for the next engine step, conversion. False when the particles' guard fired."""
        P = self.conv.particles
        if P.n_act:
            self._escape(P)
        ec = None
        if P.n_act:
            dt = float(state.scal[S_DTPREV])
            ec = self._particles(state, rec, 1, dt, dt)
        if ec is None:
            self.react[:] = 0.0
        else:
            self.react[0] = ec.fxn
            self.react[1] = ec.fyn
            self.dt_react = dt
            if ec.expelled[0] > 0:  # plastic impacts: their impulses (jxn, jyn are zero otherwise)
                self._pend(ec.jxn, ec.jyn, dt)
        if rec.status != "ok":
            return False
        self._convert(state)
        return True

    def _compiled_args(self, state):
        """The threads the compiled lockstep loop runs on (:attr:`threads`, a :class:`solver.threads.ThreadChoice`
        timing its calls), or None when a step must run in Python: no particle, their accelerations to be
        recomputed (after a conversion or an escape), impulses pending, no boundary edge, a dead element not
        converted yet, or the engine already unstable."""
        P = self.conv.particles
        if (P.n_act == 0 or not P.forces_valid or self.h_pending > 0.0 or state.guard[0] != 0
                or state.e_initial is None or P.scratch.get("f_edge") is None or P.scratch.get("edge_pairs") is None):
            return None
        if self._boundary(state).shape[0] == 0 or np.any((state.alive == 0) & (self.conv.elem_particle >= 0)):
            return None  # no edges, or an element died outside the engine's steps and waits for conversion
        return self.threads.next()

    def _run_compiled(self, state, t_stop: float, chunk_steps: int, threads: int):
        """Lockstep steps in the compiled loop (:func:`solver.hybrid.lockstep.lockstep_steps`) with the
        coupler's and the particles' records handed over and back. Returns (why it returned, engine steps
        done, the engine's StepRecord of its last step)."""
        P = self.conv.particles
        order, cell_of, pairs = loop._buffers(P)
        if self._fn is None or self._fn.shape[1] != state.x.size:
            self._fn = np.zeros((4, state.x.size))
        fe = P.scratch["f_edge"]
        state.k_pen = float(self.k_pen)
        state.mu = float(self.mu)
        acc = self._acc
        acc[:] = (self.node_work, self.sph_steps, self.tool_work, self.couple_work, self.impact_loss, self.contact_loss,
                  self.n_expelled, self.max_expel, self.n_expel_no_free, self.n_expel_no_edge, self.max_overlap,
                  self.max_tool_penetration, self.dt_react, P.steps, P.time, self.n_bin_builds)
        valid = self._lb_bins is not None and self._lb_key == self.edge_key
        lstart, litems, lgrid = self._lb_bins if valid else _NO_BINS
        mirror = loop.NO_MIRROR if P.mirror_idx is None else (P.mirror_idx, P.mirror_c)
        codes = self._codes
        old = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            lstart, litems, lgrid, lvalid = lockstep_steps(
                int(chunk_steps), float(t_stop), *fem_loop.bundles(state, self.k_pen, self.mu),
                P.F, P.I, P.S, pairs, P.act, P.n_act, P.mats, P.prm, order, cell_of, float(self.k_tool), float(self.mu),
                self._tool_sph, self._tout, self._sout, *mirror, loop._NO_QUAD if P.quad is None else P.quad,
                self.edges, self.eitems, np.array(self.box), float(self.edge_max + self.r_c), float(self.k_couple),
                float(self.r_c), float(self.v_sep), state.quads, self.live, state.mass,
                fe[0], fe[1], self._fn[0], self._fn[1], self._fn[2], self._fn[3], self._eout, self._expelled,
                loop.edge_pairs(P), lstart, litems, lgrid, self._lb_box, self._lb_x, self._lb_y, int(valid),
                float(BIN_SKIN * float(P.prm[pp.P_DP])), self.react, self.tool_force_sum, acc, codes)
        finally:
            numba.set_num_threads(old)
        self.n_compiled_calls += 1
        if lvalid:
            self._lb_bins = (lstart, litems, lgrid)
            self._lb_key = self.edge_key
        (self.node_work, self.tool_work, self.couple_work, self.impact_loss, self.contact_loss, self.max_expel,
         self.max_overlap, self.max_tool_penetration, self.dt_react, P.time) = (
            float(acc[A_NODE_WORK]), float(acc[A_TOOL_WORK]), float(acc[A_COUPLE_WORK]), float(acc[A_IMPACT_LOSS]),
            float(acc[A_CONTACT_LOSS]), float(acc[A_MAX_EXPEL]), float(acc[A_MAX_OVERLAP]),
            float(acc[A_MAX_TOOL_PEN]), float(acc[A_DT_REACT]), float(acc[A_P_TIME]))
        (self.sph_steps, self.n_expelled, self.n_expel_no_free, self.n_expel_no_edge, P.steps, self.n_bin_builds) = (
            int(acc[A_SPH_STEPS]), int(acc[A_N_EXPELLED]), int(acc[A_NO_FREE]), int(acc[A_NO_EDGE]),
            int(acc[A_P_STEPS]), int(acc[A_BIN_BUILDS]))
        code, k = int(codes[0]), int(codes[2])
        rec = fem_loop.step_record(state, 1 if k else 0)
        if code == SPH_STOP:
            P.forces_valid = False
            self._sph_failed(state, rec, loop.STATUS_TEXT[int(codes[1])] + loop._where(P))
        return code, k, rec

    def _subcycled(self, engine, state, t_stop: float, chunk_steps: int):
        """Engine sub-chunks of ``numerics.coupling_sync_steps`` steps, each followed by conversion and the
        particles' own steps over the same interval against the edges where the engine left them; the
        reactions J gathered over a particle sub-chunk of length h act on the nodes as J / h over the next
        engine sub-chunk (:meth:`_engine`). The nodes take them a sub-chunk late, at their velocities of
        then: the pair's net work is not zero (a sub-chunk's lag in the work booking)."""
        P = self.conv.particles
        rec = None
        done = 0
        while done < chunk_steps and state.time < t_stop * (1 - 1e-12):
            t0 = state.time
            # before the first deletion nothing couples: longer engine sub-chunks save Python overhead
            n_sub = self.sync_every if (P.n_act or self.n_alive_total != int(state.alive.sum())) else 10 * self.sync_every
            rec, k = self._engine(engine, state, n_sub, t_stop, None)
            done += k
            if rec.status != "ok" or k == 0:
                break
            self._convert(state)
            if P.n_act and self.t_sph is None:
                self.t_sph = state.time  # the first particles are born at the engine's time
            if P.n_act == 0:
                self.t_sph = None
                continue
            self._escape(P)
            if P.n_act == 0:
                continue
            # the particles follow the engine's clock in whole steps of at least half their stable step:
            # an engine sub-chunk cut short to land on a sample time does not make them take a tiny step
            h = state.time - self.t_sph
            dt_sph = loop.stable_dt(P, self.k_tool)
            if h < 0.5 * dt_sph:
                continue
            n = max(1, int(math.ceil(h / dt_sph)))
            ec = self._particles(state, rec, n, h / n, (state.time - t0) / k)
            self.t_sph = state.time
            if ec is not None:
                self._pend(ec.fxn * (h / n) + ec.jxn, ec.fyn * (h / n) + ec.jyn, h)
            if rec.status != "ok":
                break
        return rec

    def impulse_in_flight(self) -> np.ndarray:
        """The momentum [N s/m] (x, y) the nodes are still owed for what the particles already took: the
        pending impulses, and in lockstep the half-kick (dt / 2) R the particles took of the reactions R
        that act on the nodes in the next engine step. Nodes + particles + this is conserved."""
        return self.j_pending.sum(axis=1) + 0.5 * self.dt_react * self.react.sum(axis=1)

    # ------------------------------------------------------------------ reporting
    def _containing(self, state, px: np.ndarray, py: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For each point, the living element it lies deepest inside (-1: none) and how deep (distance
        to that element's nearest edge line, 0 when outside): point in a convex quad, deeper than
        INSIDE_TOL behind each of its edges (:func:`solver.sph.coupling.depth_inside`)."""
        elem = np.full(px.size, -1, np.int64)
        depth = np.zeros(px.size)
        if px.size:
            lstart, litems, lgrid = self._bin_elements(state, px, py, 0.0)
            depth_inside(np.ascontiguousarray(px), np.ascontiguousarray(py), state.quads, state.x, state.y, lgrid,
                         lstart, litems, elem, depth)
        return elem, depth

    def check_inside(self, state) -> int:
        """Count the active particles inside a living element now and keep the largest count and depth
        (distance to that element's nearest edge) seen: the issue's "particles never enter an intact
        element", measured (:meth:`_containing`)."""
        P = self.conv.particles
        a = P.active_indices()
        if a.size == 0:
            return 0
        elem, depth = self._containing(state, P.F[X, a], P.F[Y, a])
        n_in = int(np.count_nonzero(elem >= 0))
        self.max_inside = max(self.max_inside, n_in)
        if n_in:
            self.max_inside_depth = max(self.max_inside_depth, float(depth.max()))
        return n_in

    def energy_terms(self) -> dict:
        """The particles' energies [J/m] (kinetic, stress work, viscous, artificial stress), the kinetic
        energy lost at conversion and the tool's work on the particles."""
        e = self.conv.particles.energies()
        return {"sph_kinetic": e["kinetic"], "sph_internal": e["internal"], "sph_viscous": e["viscous"],
                "sph_artificial_stress": e["artificial_stress"], "conversion_loss": e["conversion"],
                "sph_tool_work": self.tool_work, "sph_coupling_work": self.couple_work,
                "coupling_node_work": self.node_work, "coupling_impact_loss": self.impact_loss,
                "coupling_contact_loss": self.contact_loss, "coupling_spring": self.spring_energy(),
                "coupling_net_work": self.coupling_net_work,
                "sph_escaped_kinetic": self.escaped_ke,
                "sph_kinetic_received": self.conv.ke_from_nodes - e["conversion"]}

    def spring_energy(self) -> float:
        """E_s [J/m]: the energy the particle-edge contact springs hold now, k c^2 / 2 over the pairs."""
        pairs = self.conv.particles.scratch.get("edge_pairs")
        return 0.0 if pairs is None else spring_energy(pairs, self.k_couple)

    @property
    def coupling_net_work(self) -> float:
        """W_n + W_p + D_imp + D_c + E_s [J/m]: the work the coupling's pair forces did on nodes and particles
        together, with what their contacts dissipated by design (the plastic impacts' D_imp, the contact
        springs' state changes D_c) and what the springs hold now (E_s) taken out: zero but for the
        integration (:meth:`hybrid_balance`)."""
        return self.node_work + self.couple_work + self.impact_loss + self.contact_loss + self.spring_energy()

    def hybrid_balance(self, fem_energies: dict) -> tuple[float, float]:
        """(residual [J/m], energy error) of the energy balance of engine + particles as one body: what the
        tool put into both, minus what both hold. The engine's balance books the kinetic energy its nodes
        gave up at conversion as removed and the coupling forces on its nodes (state.fext) as external work
        W_n; the particles received that kinetic energy (minus the conversion loss), the tool's work and
        the coupling forces' work W_p, and hold it as kinetic, stress work, viscous and artificial-stress
        energy. The coupling is internal to the body: its net work W_n + W_p is energy the coupling's
        numerics made or lost, apart from the plastic impacts of particles put back out of elements, which
        lose D_imp = sum (1/2) mu v_n^2 by design (mu: the reduced mass of particle and edge point; booked as
        dissipated), what the contact springs dissipate by design D_c (the force the separation-speed
        limit holds back, along the path; a compressed pair leaving reach or forgotten, less what a new
        pair's carried compression adds; solver.sph.coupling) and the springs' energy now E_s (stored). So

            residual = engine residual - W_n + received + particles' tool work - particle energies - D_imp
                       - D_c - E_s,

        and the error is |residual| over the larger of the inputs (the tool's work on nodes and particles,
        the initial energy) and the stored energies. The coupling works are not inputs: counting them as
        such (residual + W_n + W_p) would hide the coupling's net work, which an exact coupling keeps at
        zero."""
        t = self.energy_terms()
        fe = fem_energies
        e_sph = (t["sph_kinetic"] + t["sph_internal"] + t["sph_viscous"] + t["sph_artificial_stress"]
                 + t["sph_escaped_kinetic"])
        res = (fe.get("residual", math.nan) - self.node_work + t["sph_kinetic_received"] + self.tool_work
               - e_sph - self.impact_loss - self.contact_loss - t["coupling_spring"])
        inputs = abs(fe.get("external", 0.0) - self.node_work) + abs(fe.get("initial", 0.0)) + abs(self.tool_work)
        stored = fe.get("internal", 0.0) + fe.get("kinetic", 0.0) + fe.get("hourglass", 0.0) + e_sph
        return res, abs(res) / max(inputs, stored, 1e-300)

    def metrics(self) -> dict:
        P = self.conv.particles
        e = P.energies()
        a = P.active_indices()
        return {"n_particles_dormant_allocated": P.n, "n_particles_active": P.n_act,
                "n_converted_elements": self.conv.n_converted, "sph_steps": self.sph_steps,
                "sph_kinetic_energy_J_per_m": e["kinetic"], "sph_internal_energy_J_per_m": e["internal"],
                "sph_viscous_energy_J_per_m": e["viscous"],
                "sph_artificial_stress_energy_J_per_m": e["artificial_stress"],
                "conversion_kinetic_energy_loss_J_per_m": e["conversion"],
                "sph_fully_fractured": int(np.sum(P.F[pp.DMG, a] >= 1.0)) if a.size else 0,
                "sph_max_overlap_with_elements_um": self.max_overlap * 1e6,
                "sph_particles_inside_elements_max": self.max_inside,
                "sph_max_depth_inside_elements_um": self.max_inside_depth * 1e6,
                "sph_born_inside_moved": self.n_born_moved, "sph_born_inside_kept": self.n_born_kept,
                "sph_born_inside_tool": self.n_born_in_tool,
                "sph_born_inside_max_shift_um": self.max_birth_shift * 1e6,
                "sph_expelled_from_elements": self.n_expelled, "sph_max_expel_depth_um": self.max_expel * 1e6,
                "sph_expelled_onto_another_element": self.n_expel_no_free,
                "sph_inside_with_no_boundary_in_reach": self.n_expel_no_edge,
                "sph_max_tool_penetration_um": self.max_tool_penetration * 1e6,
                "coupling_work_on_particles_J_per_m": self.couple_work, "coupling_work_on_nodes_J_per_m": self.node_work,
                "coupling_net_work_J_per_m": self.coupling_net_work,
                "coupling_impact_loss_J_per_m": self.impact_loss,
                "coupling_contact_state_loss_J_per_m": self.contact_loss,
                "coupling_spring_energy_J_per_m": self.spring_energy(),
                "sph_reaction_impulse_pending_N_s_per_m": float(np.abs(self.j_pending).sum()),
                "sph_escaped_particles": self.n_escaped,
                "sph_escape_box": f"particles beyond {ESCAPE_MARGIN:g} workpiece size(s) outside the workpiece are taken out",
                "sph_contact_radius_um": self.r_c * 1e6, "sph_smoothing_length_um": P.h * 1e6,
                "sph_spacing_um": float(P.prm[pp.P_DP]) * 1e6, "sph_spacing_from": self.dp_from}

    def frame(self) -> dict:
        """Positions, material, damage and stress of the active particles (for the chip frames)."""
        P = self.conv.particles
        a = P.active_indices()
        F = P.F
        return {"particles_x": F[X, a].copy(), "particles_y": F[Y, a].copy(),
                "particles_material": P.I[pp.MAT, a].copy(),
                "particles_damage": F[pp.DMG, a].copy(),
                "particles_stress": np.stack([F[pp.ESXX, a], F[pp.ESYY, a], F[pp.ESXY, a]], axis=1)}


def make_coupler(scene, mesh, si, state, k_tool: float, k_pair: float, mu: float) -> HybridCoupler | None:
    """The coupler when the scene converts failed elements to particles (hybrid2d), else None:
    a scene without conversion allocates no particles."""
    if not getattr(scene, "uses_particles", False):
        return None
    c = HybridCoupler(mesh, si, state, k_tool, k_pair, mu)
    return c if c.conv is not None else None
