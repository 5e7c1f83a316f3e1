"""Classic explicit FEM as the cutting scene's engine (:class:`solver.engine.Engine`).

Built from the scene: the engine's state (:func:`solver.fem.build_state`) with the cut's hourglass
guard (:func:`hourglass_limit`); the stable step, then the rigid tool's penalty 1.0 m_i / dt^2 on a
node of mass m_i (:func:`solver.contact.tool_contact`, :data:`solver.contact.TOOL_ALPHA`), which by
construction does not limit it, and k = 0.1 m_min / dt^2, the lightest node's
(:func:`solver.contact.contact_stiffness`), for the deformable pairs (the fragment contact, the
hybrid's particle-edge coupling); erosion of crushed elements; the fragment contact when elements
are deleted. Each chunk runs the compiled steps (:func:`solver.fem.advance`), then rebuilds the
fragments' exposed boundary when elements were deleted.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .. import units as u
from ..contact import TOOL_ALPHA, FragmentContact, contact_stiffness
from ..outputs import frame
from .loop import advance as advance_steps
from .state import build_state
from .timestep import stable_dt
from .state import E_FRAG, P_ERODE, P_HGMAX, S_DTCRIT, TOOL_FORCE_ROWS

#: erosion of crushed elements (explicit codes' time-step erosion, e.g. LS-DYNA's ERODE/DTMIN):
#: with element deletion on, the engine deletes an element whose critical step falls below
#: ERODE_FRACTION x the run's initial critical step, long before its guard (1/100) would end the run
ERODE_FRACTION = 0.2
#: the exposed boundary of the fragment contact is rebuilt after every chunk of at most this many
#: steps in which elements were deleted (the engine applies the contact at every step)
FRAG_REBUILD_STEPS = 50
#: travel into the workpiece (in element sizes) after which the hourglass guard is armed
HG_ARM_TRAVEL_ELEMENTS = 2.0


def hourglass_limit(n_across: int) -> float:
    """The hourglass guard's limit for a cutting scene: max(0.1, min(0.5, 2 / n^2)).

    The engine's quads use physical (assumed-strain) hourglass stabilisation: a beam bent
    with n elements across stores 1/n^2 of its exact bending energy in the hourglass modes
    (each element's linear part sees only its layer's mean strain). Fibres fail by bending at
    0 deg, so a correct bending solution with 3 elements across already sits at 11 %, above the
    generic 10 % limit. Twice the bending share (at least 10 %, at most 50 %) still catches
    spurious hourglassing, which grows without bound.
    """
    return max(0.1, min(0.5, 2.0 / max(n_across, 1) ** 2))


#: the far field's damping is held below this fraction of 1 / dt: the central difference integrates the drag
#: -c v explicitly, stable for c dt < 2 and without reversing the velocity for c dt < 1
FAR_FIELD_DAMPING_DT_MAX = 0.5


def far_field_damping(state, mesh, c: float, dt: float) -> dict | None:
    """Mass-proportional damping ``c`` [1/s] on the far field's nodes (:meth:`solver.mesh.Mesh.far_field_nodes`):
    an absorbing region round the cut, as the absorbing layers of wave problems in bounded meshes (Rayleigh
    damping graded or constant in a layer; Semblat, Lenti & Gandomi 2011, Soil Dyn. Earthq. Eng. 31:1414). Its
    dissipation is booked with the damping's (energy ``viscous``). At most FAR_FIELD_DAMPING_DT_MAX / dt.
    Returns what was set (None when ``c`` is 0)."""
    if not c > 0.0:
        return None
    nodes = mesh.far_field_nodes()
    used = min(c, FAR_FIELD_DAMPING_DT_MAX / dt)
    state.cnode[nodes] = used
    return {"nodes": int(nodes.sum()), "per_us": used / u.PER_US, "asked_per_us": c / u.PER_US,
            "capped": bool(used < c)}


def _nbytes(state) -> int:
    return int(sum(v.nbytes for v in vars(state).values() if isinstance(v, np.ndarray)))


class FemEngine:
    """The cutting scene's classic-FEM engine (module docstring)."""

    modules = ("solver.contact", "solver.fem")
    force_parts: dict[str, str] = {}

    def __init__(self, scene, si, mesh, state, build_arrays: dict, dt0: float, dt_limit, k_tool: float,
                 k_pair: float, mu: float, frag: FragmentContact | None, hg_limit: float):
        self.scene, self.si, self.mesh, self.state = scene, si, mesh, state
        self.build_arrays = build_arrays
        self.dt0, self.dt_limit = dt0, dt_limit
        self.k_tool, self.k_pair, self.mu = k_tool, k_pair, mu
        self.frag = frag
        self.hg_limit = hg_limit
        self.hg_armed = False

    @classmethod
    def build(cls, scene, si, mesh, tool) -> FemEngine:
        return cls(**cls.parts(scene, si, mesh, tool))

    @staticmethod
    def parts(scene, si, mesh, tool) -> dict:
        """The engine's state and contact stiffnesses, its step, erosion and fragment contact."""
        num = scene.numerics
        t0 = time.perf_counter()
        state = build_state(mesh, si, tool=tool, hourglass_ratio_max=hourglass_limit(int(num.elements_across_fibre)))
        arrays = {"engine_state": {"bytes": _nbytes(state), "seconds": time.perf_counter() - t0}}

        # the time step and the contact stiffnesses (the tool's 1.0 m_min / dt^2, the deformable pairs'
        # 0.1 m_min / dt^2: neither limits the step)
        dt0, dt_limit = stable_dt(state)
        mass = np.asarray(state.mass)
        m_min = float(mass[mass > 0].min())
        k_tool = contact_stiffness(m_min, dt0, num.contact_stiffness_factor, TOOL_ALPHA)
        k_pair = contact_stiffness(m_min, dt0, num.contact_stiffness_factor)
        mu = float(si.friction)
        dt0, dt_limit = stable_dt(state, k_tool)
        dt0_crit = dt0 / float(state.params[0])  # the critical step at CFL 1
        state.far_field = far_field_damping(state, mesh, float(si.far_field_damping), dt0)
        if scene.physics.element_deletion:
            state.params[P_ERODE] = ERODE_FRACTION * dt0_crit
        frag = None
        if scene.physics.fragment_contact and scene.physics.element_deletion:
            # the deformable pairs' penalty (contact.PAIR_ALPHA), applied at every step
            frag = FragmentContact(mesh.quads, mesh.n_nodes, k_pen=k_pair)  # its arrays come with the first deletion
        # the hourglass check is armed once the tool has travelled HG_ARM_TRAVEL_ELEMENTS elements into
        # the workpiece (:meth:`start_sample`): at first contact one node load on a nearly unstrained body
        # makes the ratio of hourglass to strain energy meaningless (both are tiny); the ratio is recorded
        # throughout
        hg_limit = float(state.params[P_HGMAX])
        state.params[P_HGMAX] = 1.0
        return dict(scene=scene, si=si, mesh=mesh, state=state, build_arrays=arrays, dt0=dt0, dt_limit=dt_limit,
                    k_tool=k_tool, k_pair=k_pair, mu=mu, frag=frag, hg_limit=hg_limit)

    # ------------------------------------------------------------------ the run
    @property
    def time(self) -> float:
        return self.state.time

    @property
    def steps(self) -> int:
        return self.state.steps

    @property
    def tool(self) -> np.ndarray:
        return np.asarray(self.state.tool)

    def start_sample(self, travel: float) -> None:
        self.state.tool_out[2] = 0.0
        if not self.hg_armed and travel >= HG_ARM_TRAVEL_ELEMENTS * float(self.si.element_size):
            self.state.params[P_HGMAX] = self.hg_limit
            self.hg_armed = True

    def advance(self, t_stop: float, n_steps: int):
        chunk = min(n_steps, FRAG_REBUILD_STEPS) if self.frag is not None else n_steps
        rec = self._steps(t_stop, chunk)
        frag, state = self.frag, self.state
        if frag is not None:
            if frag.needs_rebuild(state):
                t_fr = time.perf_counter()
                frag.rebuild(state)
                frag.seconds += time.perf_counter() - t_fr
            frag.grow(state)
        return rec

    def _steps(self, t_stop: float, n_steps: int):
        """The engine's compiled steps (the hybrid couples its particles here)."""
        return advance_steps(self.state, n_steps, None, k_pen=self.k_tool, mu=self.mu, t_stop=t_stop)

    def stable_step(self) -> float:
        # CFL x critical (not a step cut short to land on a sample time)
        return float(self.state.scal[S_DTCRIT]) * float(self.state.params[0])

    def tool_force(self, part: str = "") -> np.ndarray:
        return self.state.tool_out[TOOL_FORCE_ROWS]

    def max_penetration(self) -> float:
        return float(self.state.tool_out[2])

    def overloaded(self) -> int:
        return np.count_nonzero(self.state.fail_mode < 0)  # far-field elements past their criterion

    def energies(self) -> dict:
        return dict(self.state.energies)

    def check(self) -> None:
        pass

    def frame(self, fields) -> dict:
        """A chip frame: element damage is 1 for a deleted element, else the largest damage of its interfaces."""
        state, mesh = self.state, self.mesh
        px, py = self.node_positions()
        failed = self.failed_elements()
        dmg = failed.astype(np.float64)
        if mesh.n_cohesive and "damage" in fields:
            cd = np.asarray(state.dmg).max(axis=1)
            for side in range(2):
                np.maximum.at(dmg, mesh.cohesive_elems[:, side], cd)
            dmg[failed] = 1.0
        stress = np.asarray(state.stress)[:, :3] if "stress" in fields else None
        out = frame(fields, px, py, mesh.material, failed, dmg, stress)
        if "damage" in fields and mesh.n_cohesive:
            out["cohesive_damage"] = np.asarray(state.dmg).max(axis=1).astype(np.float32)
        return out

    # ------------------------------------------------------------------ the workpiece at the end
    def failed_elements(self) -> np.ndarray:
        return np.asarray(self.state.alive) == 0

    def failed_cohesive(self) -> np.ndarray:
        """Cohesive elements that failed: fully debonded (1) or removed with a deleted neighbour (2)."""
        state, mesh = self.state, self.mesh
        return np.asarray(state.cstate) >= 1 if mesh.n_cohesive and np.asarray(state.cstate).size else np.zeros(mesh.n_cohesive, bool)

    def node_positions(self) -> tuple[np.ndarray, np.ndarray]:
        return np.asarray(self.state.x), np.asarray(self.state.y)

    def node_alive(self) -> np.ndarray:
        return np.asarray(self.state.node_active).astype(bool)

    # ------------------------------------------------------------------ reporting
    def energy_error(self, energies: dict) -> float:
        return float(energies.get("energy_error", math.nan))

    def energy_warning(self, error: float, energies: dict, metrics: dict) -> str:
        return ("the energy balance does not close; refine numerics.element_size_um or lower numerics.cfl / "
                "numerics.speed_scaling and compare")

    def metrics(self, energies: dict) -> dict:
        state, e_last = self.state, energies
        m = {}
        # the part of the residual the cohesive elements make (solver.fem.energy), already in energy_error
        m["cohesive_unaccounted_J_per_m"] = float(e_last.get("cohesive_unaccounted", 0.0))
        m["fragment_contact_work_J_per_m"] = float(state.en[E_FRAG])
        m["fragment_max_penetration_um"] = float(state.fr_out[0]) / u.UM
        m["kinetic_internal_ratio"] = float(e_last.get("kinetic_internal_ratio", math.nan))
        m["hourglass_guard"] = f"armed after {HG_ARM_TRAVEL_ELEMENTS:g} element sizes of travel, limit {self.hg_limit:g}"
        m["hourglass_energy_ratio"] = float(e_last.get("hourglass", math.nan) / max(e_last.get("internal", 0.0) + e_last.get("hourglass", 0.0), 1e-300))
        m["hourglass_energy_J_per_m"] = float(e_last.get("hourglass", math.nan))
        m["added_mass_fraction"] = float(state.added_mass_fraction)
        m["contact_stiffness_N_per_m2"] = self.k_tool  # the tool's at the lightest node; a node of mass m_i has k_tool m_i / m_min
        m["pair_contact_stiffness_N_per_m2"] = self.k_pair  # fragments' and particle-edge springs' (deformable pairs)
        m["n_eroded_elements"] = int(np.sum((np.asarray(state.alive) == 0) & (np.asarray(state.fail_mode) == 9)))
        m["erosion"] = (f"elements whose critical step fell below {ERODE_FRACTION:g} x the initial one are deleted (crushed)"
                        if self.scene.physics.element_deletion else "off (no element deletion)")
        first = next((ev["time_s"] for ev in state.events), math.nan)
        m["first_failure_time_s"] = float(first)
        far = getattr(state, "far_field", None)
        m["far_field_damping"] = ("off" if far is None else
                                  f"c = {far['per_us']:.4g} per us on the {far['nodes']} nodes only EHM elements hold"
                                  + (f" (asked {far['asked_per_us']:.4g}, held at {FAR_FIELD_DAMPING_DT_MAX:g} / dt)"
                                     if far["capped"] else ""))
        m["fragment_contact"] = ("off" if self.frag is None else
                                 f"node-to-edge penalty at every step, k = the tool's; boundary rebuilt {self.frag.rebuilds} times")
        return m

    def arrays(self) -> dict:
        arrays = dict(self.build_arrays)
        frag = self.frag
        if frag is not None and frag.rebuilds:  # built once an element was deleted (scenes with fragment contact)
            fr = [v for k, v in vars(self.state).items() if isinstance(v, np.ndarray) and (k.startswith("fr_") or k.startswith("ff"))]
            arrays["fragment_contact"] = {"bytes": int(sum(a.nbytes for a in fr)), "seconds": frag.seconds,
                                          "rebuilds": frag.rebuilds}
        return arrays
