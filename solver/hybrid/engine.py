"""The FEM-SPH hybrid as the cutting scene's engine (:class:`solver.engine.Engine`).

The classic FEM engine (:class:`solver.fem.engine.FemEngine`) with dormant particles in the converting
elements (:class:`solver.hybrid.coupler.HybridCoupler`): its chunks are the coupled step (engine steps,
conversion, the particles' steps and their reactions on the nodes); the particles' part of the tool
force is reported apart (series ``F{c,t}_particles*``, metrics ``sph_*``); the energy error is the
balance of engine and particles as one body (the engine's own stays as ``energy_error_fem_part``);
the particles' energies, checks, frames and metrics join the engine's. A scene that converts no
element allocates no particles and runs as classic FEM.
"""

from __future__ import annotations

import math

import numpy as np

from .. import fem
from ..fem.engine import FemEngine
from .coupler import HybridCoupler, make_coupler


def coupling_made(energies: dict, metrics: dict) -> float | None:
    """The particle-element coupling's net work [J/m] when it is more than half the hybrid balance's residual
    (the error is then mostly the coupling's own), else None."""
    net = metrics.get("coupling_net_work_J_per_m")
    res_h = float(energies.get("residual_hybrid", math.nan))
    return net if net is not None and math.isfinite(res_h) and abs(net) > 0.5 * abs(res_h) else None


class HybridEngine(FemEngine):
    """The cutting scene's FEM-SPH engine (module docstring)."""

    modules = (*FemEngine.modules, "solver.sph")
    force_parts = {"_particles": "sph"}  # the particles' part of the tool force, in all and by face

    def __init__(self, coupler: HybridCoupler, **parts):
        super().__init__(**parts)
        self.coupler = coupler
        self.build_arrays["particles"] = {"bytes": coupler.nbytes(), "seconds": 0.0, "n_dormant": coupler.particles.n}

    @classmethod
    def build(cls, scene, si, mesh, tool) -> FemEngine:
        parts = FemEngine.parts(scene, si, mesh, tool)
        coupler = make_coupler(scene, mesh, si, parts["state"], parts["k_tool"], parts["k_pair"], parts["mu"])
        return FemEngine(**parts) if coupler is None else cls(coupler, **parts)

    def _steps(self, t_stop: float, n_steps: int):
        # engine sub-chunks + conversion + particles
        return self.coupler.advance(fem, self.state, t_stop, n_steps)

    def tool_force(self, part: str = "") -> np.ndarray:
        return self.coupler.tool_force_sum.copy() if part == "_particles" else super().tool_force(part)

    def energies(self) -> dict:
        """The engine's energies, the particles' and the energy error of the two as one body."""
        e = super().energies()
        e.update(self.coupler.energy_terms())
        res_h, err_h = self.coupler.hybrid_balance(self.state.energies)
        e["energy_error_hybrid"] = err_h
        e["residual_hybrid"] = res_h
        return e

    def check(self) -> None:
        self.coupler.check_inside(self.state)

    def frame(self, fields) -> dict:
        fr = super().frame(fields)
        fr.update(self.coupler.frame())  # the active particles
        return fr

    def energy_error(self, energies: dict) -> float:
        return float(energies.get("energy_error_hybrid", math.nan))

    def energy_warning(self, error: float, energies: dict, metrics: dict) -> str:
        net = coupling_made(energies, metrics)
        if net is not None:  # most of it is the particle-element coupling's own (solver.hybrid.coupler)
            return (f"the particle-element coupling made {net:.3g} J/m; the particles' part of the forces carries that "
                    "error (docs/validation.md; with numerics.coupling_sync_steps above 1 the nodes take the reactions late)")
        return super().energy_warning(error, energies, metrics)

    def metrics(self, energies: dict) -> dict:
        """The engine's metrics, the particles' counts and energies, and the engine's own energy error."""
        m = super().metrics(energies)
        m.update(self.coupler.metrics())
        m["energy_error_fem_part"] = super().energy_error(energies)
        return m
