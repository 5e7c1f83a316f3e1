"""The FEM-SPH hybrid on the 3D strip as the cutting scene's engine (fidelity ``hybrid3d``).

The 3D engine (:class:`solver.fem3d.engine.Fem3dEngine`) with its failed fibre and matrix elements turned
into 3D SPH particles during the run (:class:`solver.hybrid.coupler3d.Hybrid3dCoupler`): its chunks are the
coupled lockstep (engine step capped at the particles' stable step, the particles' step with the tool and
the face springs, conversion). The particles' part of the tool force is reported apart (series
``F{c,t}_particles*``, metrics ``sph_*``), per metre of strip width as the nodes'; the energy error is the
balance of engine and particles as one body (the engine's own stays as ``energy_error_fem_part``); the
particles' energies, checks, frames and metrics join the engine's. Without element deletion no element
converts and the run is the fem3d engine's.
"""

from __future__ import annotations

import numpy as np

from ..fem3d import loop
from ..fem3d.engine import Fem3dEngine
from .coupler3d import Hybrid3dCoupler
from .engine import HybridEngine, coupling_made


class Hybrid3dEngine(Fem3dEngine):
    """The cutting scene's FEM-SPH engine on the 3D strip (module docstring)."""

    modules = (*Fem3dEngine.modules, "solver.sph3d", "solver.hybrid")
    force_parts = {"_particles": "sph"}

    def __init__(self, coupler: Hybrid3dCoupler, *args, **kw):
        super().__init__(*args, **kw)
        self.coupler = coupler
        self.build_arrays["particles"] = {"bytes": coupler.nbytes(), "seconds": 0.0}

    @classmethod
    def build(cls, scene, si, mesh, tool) -> Fem3dEngine:
        eng = Fem3dEngine.build(scene, si, mesh, tool)
        if not bool(scene.physics.element_deletion):
            return eng
        coupler = Hybrid3dCoupler.for_strip(si, mesh, eng.state, eng.width)
        hyb = cls(coupler, scene, si, mesh, eng.state, eng.build_arrays, eng.dt0, eng.dt_limit, eng.width)
        hyb.frag = eng.frag
        return hyb

    def _steps(self, t_stop: float, n_steps: int):
        """Up to n_steps engine steps in lockstep with the particles (:meth:`Hybrid3dCoupler.advance`); a
        cohesive element on a deleted element goes at once, not at the chunk's end: a converted element's
        nodes may have no mass left, and a cohesive element on them would pull its other side against a
        node that does not respond (energy from nowhere)."""
        return self.coupler.advance(self.state, t_stop, n_steps, after_deletion=self._drop_cohesive_of_deleted)

    def stable_step(self) -> float:
        return float(min(loop.stable_dt(self.state), self.coupler.dt_cap()))

    def tool_force(self, part: str = "") -> np.ndarray:
        if part == "_particles":
            return self.coupler.tool_force_sum / self.width
        return super().tool_force(part)

    def energies(self) -> dict:
        """The engine's energies, the particles' and the energy error of the two as one body [J/m]."""
        e = super().energies()
        w = self.width
        e.update({k: v / w for k, v in self.coupler.energy_terms(self.state).items()})
        fem_j = {k: v * w for k, v in e.items() if k in ("residual", "external", "initial", "internal", "kinetic",
                                                         "hourglass", "deleted")}
        res, err = self.coupler.hybrid_balance(self.state, fem_j)
        e["energy_error_hybrid"] = err
        e["residual_hybrid"] = res / w
        return e

    def check(self) -> None:
        self.coupler.check_inside(self.state)

    def frame(self, fields) -> dict:
        fr = super().frame(fields)
        fr.update(self.coupler.frame())
        return fr

    energy_error = HybridEngine.energy_error  # the hybrid balance's, as in 2D

    def energy_warning(self, error: float, energies: dict, metrics: dict) -> str:
        net = coupling_made(energies, metrics)
        if net is not None:
            return (f"the particle-face coupling made {net:.3g} J/m (springs lost with their faces, or the "
                    "integration); the particles' part of the forces carries that error")
        return super().energy_warning(error, energies, metrics)

    def metrics(self, energies: dict) -> dict:
        m = super().metrics(energies)
        m.update(self.coupler.metrics(self.state, self.width))
        m["energy_error_fem_part"] = Fem3dEngine.energy_error(self, energies)
        return m
