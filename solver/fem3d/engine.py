"""Classic explicit FEM on the 3D strip as the cutting scene's engine (:class:`solver.engine.Engine`).

Built from the scene and its strip (:mod:`.strip3d`): the hexahedral state (:func:`.loop.build_state`) with
the fibre, matrix and EHM laws (:func:`.laws3d.material_table3d`; the fibre's axis along the strip's fibres),
the cohesive fibre surfaces (:func:`.loop.add_cohesive`, the interface data of the scene), the supports of
the 2D workpiece (bottom and far end held) and the strip's sides held normal to themselves (symmetry planes,
:func:`.contact3d.strip_sides`), then the rigid tool, its 2D profile extruded across the strip, with the
penalty 1.0 m_i / dt^2 and Coulomb friction (:func:`.contact3d.add_tool`). Each chunk runs the compiled
steps (:func:`.loop.advance`); failed elements are deleted inside them, and with element deletion on a
crushed element is deleted too (failure mode 9; the 2D engine's time-step erosion): one whose current
critical step fell below ERODE_FRACTION x the initial one, or that turned inside out. The step follows the
living elements' current critical steps, as the 2D engine's. With element deletion, pieces no longer joined
(by a deleted element or a debonded interface) touch through the fragments' node-to-face contact
(:class:`.contact3d.FragmentContact3D`, physics.fragment_contact), its exposed faces rebuilt between chunks.

Forces are reported as the 2D engine's, per metre of strip width: the tool's force in all and by face
(rake, edge, clearance) summed over the steps and divided by the strip's width W, so N/m (N/mm in the
summary) compare directly with the 2D scenes and the paper's Table 2.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..contact import TOOL_ALPHA
from ..fem.engine import ERODE_FRACTION, FRAG_REBUILD_STEPS, HG_ARM_TRAVEL_ELEMENTS, FemEngine
from . import contact3d, loop
from .laws3d import material_table3d

#: rows of ``state.tool_out`` (:mod:`.contact3d`) in the 2D layout: Fx, Fy in all, then on the rake face,
#: the cutting edge and the clearance face
TOOL_FORCE_ROWS = np.array([0, 1, 5, 6, 8, 9, 11, 12])


def ogrid_hourglass_limit(n_across: int) -> float:
    """The hourglass guard's limit on the 3D strip: max(0.1, min(0.5, 3 / n^2)), n elements across a fibre.

    The 2D engine's rule (:func:`solver.fem.engine.hourglass_limit`) is twice the hourglass share of a bent
    beam. A fibre meshed with the strip's O-grid and bent as a cantilever stores 9.2 % of its bending energy
    in the hourglass modes with 4 elements across and 4.1 % with 6 (about 1.5 / n^2;
    ``tests/test_fem3d_cutting.py``), so twice that share is 3 / n^2."""
    return max(0.1, min(0.5, 3.0 / max(n_across, 1) ** 2))


def _nbytes(state) -> int:
    return int(sum(v.nbytes for v in vars(state).values() if isinstance(v, np.ndarray)))


class Fem3dEngine:
    """The cutting scene's engine on the 3D strip (module docstring)."""

    modules = ("solver.fem3d",)
    force_parts: dict[str, str] = {}

    def __init__(self, scene, si, mesh, state, build_arrays: dict, dt0: float, dt_limit: str, width: float):
        self.scene, self.si, self.mesh, self.state = scene, si, mesh, state
        self.build_arrays = build_arrays
        self.dt0, self.dt_limit = dt0, dt_limit
        self.width = width
        # the hourglass guard waits, as the 2D engine's, until the tool has travelled HG_ARM_TRAVEL_ELEMENTS elements
        # (at first contact the ratio of hourglass to strain energy of a nearly unstrained body means nothing)
        self.hg_limit = float(state.gpar[loop.P_HGMAX])
        state.gpar[loop.P_HGMAX] = 1.0
        self.hg_armed = False
        self.frag: contact3d.FragmentContact3D | None = None  # the fragments' contact (scenes with deletion)

    @classmethod
    def build(cls, scene, si, mesh, tool) -> Fem3dEngine:
        num, phys = scene.numerics, scene.physics
        t0 = time.perf_counter()
        cmat, rho, props = material_table3d(si, fibre_direction=tuple(mesh.direction), mass_scaling=float(num.mass_scaling),
                                            fibre_plasticity=bool(phys.fibre_plasticity), ehm_failure=bool(phys.ehm_failure))
        state = loop.build_state(mesh.X, mesh.hexes, cmat, rho, mat=mesh.material, cfl=float(num.cfl), props=props,
                                 deletion=bool(phys.element_deletion),
                                 hourglass_ratio_max=ogrid_hourglass_limit(2 * int(mesh.info["n_quarter"]) + 2),
                                 delete_inverted=bool(phys.element_deletion))
        if phys.element_deletion:  # time-step erosion of crushed elements, the 2D engine's rule
            state.gpar[loop.P_ERODE] = ERODE_FRACTION * state.dt_crit
        X = mesh.X
        tol = 1e-9 * float(np.ptp(X))
        held = (np.abs(X[1] - X[1].min()) <= tol) | (np.abs(X[0] - X[0].min()) <= tol)  # bottom and far end
        state.fix[:, held] = 1
        state.vp[:, held] = 0.0
        contact3d.strip_sides(state)
        if scene.uses_cohesive and mesh.n_cohesive:
            it = si.interface
            loop.add_cohesive(state, mesh.cohesive, [it.K, it.sigma_n, it.tau, it.GIc, it.GIIc, it.eta])
        dt0 = loop.stable_dt(state)
        contact3d.add_tool(state, tool, mu=float(si.friction), dt=dt0, alpha=TOOL_ALPHA * float(num.contact_stiffness_factor))
        dt0 = loop.stable_dt(state)
        limit = "cohesive penalty" if state.dt_cohesive < state.dt_crit else "element wave speed"
        arrays = {"engine_state": {"bytes": _nbytes(state), "seconds": time.perf_counter() - t0}}
        eng = cls(scene, si, mesh, state, arrays, dt0, limit, contact3d.strip_width(state))
        if phys.fragment_contact and phys.element_deletion:  # its arrays come with the first failure
            eng.frag = contact3d.FragmentContact3D(state, sides=(float(X[2].min()), float(X[2].max())))
        return eng

    # ------------------------------------------------------------------ the run
    @property
    def time(self) -> float:
        return float(self.state.time)

    @property
    def steps(self) -> int:
        return int(self.state.steps)

    @property
    def tool(self) -> np.ndarray:
        return np.asarray(self.state.tool)

    def start_sample(self, travel: float) -> None:
        self.state.tool_out[3] = 0.0  # the deepest penetration of this sample
        if not self.hg_armed and travel >= HG_ARM_TRAVEL_ELEMENTS * float(self.si.element_size):
            self.state.gpar[loop.P_HGMAX] = self.hg_limit  # the hourglass guard, armed as the 2D engine's
            self.hg_armed = True

    def advance(self, t_stop: float, n_steps: int):
        """Steps of the stable size, the last ones shortened evenly so that the chunk lands on ``t_stop``; with
        the fragments' contact, chunks of at most FRAG_REBUILD_STEPS steps, its exposed faces rebuilt after a
        chunk in which elements were deleted or interfaces debonded (the 2D engine's rule)."""
        frag = self.frag
        rec = self._steps(t_stop, min(n_steps, FRAG_REBUILD_STEPS) if frag is not None else n_steps)
        if rec.deleted:
            self._drop_cohesive_of_deleted()
        if frag is not None:
            if frag.needs_rebuild(self.state):
                frag.rebuild(self.state)
            frag.grow(self.state)
        rec.dt_limit = self.dt_limit
        rec.status = "ok" if rec.status == "ok" else "unstable"
        return rec

    def _drop_cohesive_of_deleted(self) -> None:
        """A cohesive element whose fibre or matrix neighbour was deleted goes with it (the 2D engine's rule,
        here at the end of the chunk): it no longer joins anything."""
        state = self.state
        if not state.coh.shape[0]:
            return
        dead = np.asarray(state.alive)[self.mesh.cohesive_elems] == 0
        gone = dead.any(axis=1) & (np.asarray(state.cstate) != 2)
        state.cstate[gone] = 2
        state.dmg[gone] = 1.0

    def _steps(self, t_stop: float, n_steps: int):
        """The engine's compiled steps of a chunk (the hybrid couples its particles here)."""
        state = self.state
        dt = loop.stable_dt(state)
        left = t_stop - state.time
        n = max(1, int(math.ceil(left / dt - 1e-9)))
        if n <= n_steps:
            dt = left / n
        return loop.advance(state, min(n, n_steps), dt=dt)

    def stable_step(self) -> float:
        return float(loop.stable_dt(self.state))

    def tool_force(self, part: str = "") -> np.ndarray:
        return self.state.tool_out[TOOL_FORCE_ROWS] / self.width

    def max_penetration(self) -> float:
        return float(self.state.tool_out[3])

    def overloaded(self) -> int:
        return int(np.count_nonzero(np.asarray(self.state.fail_mode) < 0))

    def energies(self) -> dict:
        e = loop.energies(self.state)
        return {k: (v / self.width if k != "energy_error" else v) for k, v in e.items()}

    def check(self) -> None:
        pass

    def frame(self, fields) -> dict:
        """A chip frame: 3D node positions (n, 3), the elements' material, failure (1 deleted) and damage (1 for
        a deleted element, else the largest damage of the cohesive surfaces it touches), the Cauchy stress
        (ne, 6)."""
        state, mesh = self.state, self.mesh
        failed = self.failed_elements()
        out: dict[str, np.ndarray] = {}
        for f in fields:
            if f == "positions":
                out[f] = np.ascontiguousarray(state.x.T, dtype=np.float64)
            elif f == "material":
                out[f] = np.asarray(mesh.material, np.int8).copy()
            elif f == "state":
                out[f] = failed.astype(np.uint8)
            elif f == "damage":
                dmg = failed.astype(np.float64)
                if mesh.n_cohesive:
                    cd = np.asarray(state.dmg).max(axis=1)
                    node_d = np.zeros(mesh.n_nodes)
                    np.maximum.at(node_d, mesh.cohesive[:, :4].ravel(), np.repeat(cd, 4))
                    dmg = np.maximum(dmg, node_d[mesh.hexes].max(axis=1))
                    out["cohesive_damage"] = cd.astype(np.float32)
                out[f] = dmg.astype(np.float32)
            elif f == "stress":
                out[f] = loop.cauchy_stress(state).astype(np.float32)
        return out

    # ------------------------------------------------------------------ the workpiece at the end
    def failed_elements(self) -> np.ndarray:
        return np.asarray(self.state.alive) == 0

    def failed_cohesive(self) -> np.ndarray:
        return np.asarray(self.state.cstate) >= 1

    def node_positions(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.state.x[0]), np.asarray(self.state.x[1])

    def node_alive(self) -> np.ndarray:
        alive = np.zeros(self.mesh.n_nodes, bool)
        alive[self.mesh.hexes[self.failed_elements() == 0].ravel()] = True
        return alive

    # ------------------------------------------------------------------ reporting
    energy_error = FemEngine.energy_error  # the balance's residual, and what to do when it does not close
    energy_warning = FemEngine.energy_warning

    def metrics(self, energies: dict) -> dict:
        e = energies
        m = {"strip_width_um": self.width * 1e6, "strip_pitches": int(getattr(self.si, "strip_pitches", 1)),
             "elements_round_fibre": int(self.mesh.info.get("elements_round_fibre", 8))}
        internal = float(e.get("internal", 0.0))
        m["kinetic_internal_ratio"] = float(e.get("kinetic", math.nan)) / max(internal, 1e-300)
        m["hourglass_energy_ratio"] = float(e.get("hourglass", math.nan)) / max(internal + float(e.get("hourglass", 0.0)), 1e-300)
        m["hourglass_energy_J_per_m"] = float(e.get("hourglass", math.nan))
        m["hourglass_guard"] = f"armed after {HG_ARM_TRAVEL_ELEMENTS:g} element sizes of travel, limit {self.hg_limit:g}"
        m["added_mass_fraction"] = float(self.scene.numerics.mass_scaling) - 1.0
        m["contact_stiffness_N_per_m2"] = float(self.state.tool_par[1]) * float(self.state.mass[self.state.mass > 0].min())
        m["cohesive_unaccounted_J_per_m"] = float(e.get("cohesive_unaccounted", 0.0))
        failed = self.failed_elements()
        m["first_failure_time_s"] = float(np.asarray(self.state.fail_time)[failed, 0].min()) if failed.any() else math.nan
        m["n_deleted_elements"] = int(failed.sum())
        m["n_eroded_elements"] = int(np.sum(failed & (np.asarray(self.state.fail_mode) == 9)))
        m["erosion"] = (f"elements whose critical step fell below {ERODE_FRACTION:g} x the initial one, or that turned "
                        "inside out, are deleted (crushed)" if self.scene.physics.element_deletion else "off")
        frag = self.frag
        m["fragment_contact"] = ("off" if frag is None else
                                 f"node-to-face penalty at every step, k = PAIR_ALPHA m_min / dt^2; exposed faces "
                                 f"rebuilt {frag.rebuilds} times")
        m["fragment_contact_work_J_per_m"] = float(self.state.fr_par[contact3d.FR_WORK]) / self.width
        m["fragment_max_penetration_um"] = float(self.state.fr_par[contact3d.FR_DEEP]) * 1e6
        return m

    def arrays(self) -> dict:
        arrays = dict(self.build_arrays)
        frag, s = self.frag, self.state
        if frag is not None and frag.rebuilds:  # built once an element was deleted or an interface debonded
            fr = (s.fr_faces, s.fr_nodes, s.fr_par, s.fr_cstart, s.fr_cent, s.fr_depth, s.ffr, s.ffrp)
            arrays["fragment_contact"] = {"bytes": int(sum(a.nbytes for a in fr)), "seconds": frag.seconds,
                                          "rebuilds": frag.rebuilds}
        return arrays
