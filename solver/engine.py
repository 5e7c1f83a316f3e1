"""The engine interface of the cutting scene: what :func:`solver.cutting.simulate` drives.

An engine holds the workpiece's discretisation and advances it in time against the rigid tool; the
cutting scene owns the clock of force samples, the steady window and the reductions. An engine is
built from the scene, its SI parameters, the mesh and the tool array (:func:`build_engine`, the
class named by the fidelity's entry in :data:`solver.run.FIDELITIES`), then, per force sample:

1. ``start_sample(travel)`` with the tool's travel into the workpiece [m];
2. ``advance(t_stop, n_steps)`` until ``time`` reaches the sample time (each call a chunk of at most
   ``n_steps`` steps), returning the engine's step record (``status``, ``finding``, ``dt_limit``);
3. the samples: ``tool_force(part)`` (running sums over steps, :data:`solver.fem.state.TOOL_FORCE_ROWS`
   layout: Fx, Fy in all, then on the rake face, the cutting edge and the clearance face), for the
   whole tool force (part ``""``) and for each part in ``force_parts`` that the engine reports apart
   (the hybrid's particles); ``max_penetration()``, ``stable_step()``, ``overloaded()``,
   ``energies()`` and ``check()``; ``frame(fields)`` when a chip frame is due.

At the end the scene reads the damaged workpiece (``failed_elements``, ``failed_cohesive``,
``node_positions``, ``node_alive``), the energy error (``energy_error``, with ``energy_warning`` when
the balance does not close), the engine's own metrics (``metrics``) and its arrays (``arrays``).
"""

from __future__ import annotations

from importlib import import_module
from typing import Protocol, runtime_checkable

import numpy as np


class StepRecord(Protocol):
    status: str  # "ok" or "unstable"
    finding: dict | None  # the stability guard's diagnosis when unstable
    dt_limit: str  # what limits the step in force


@runtime_checkable
class Engine(Protocol):
    #: the modules the engine's run uses (Result.build["modules"], after the mesher's and the tool's)
    modules: tuple[str, ...]
    #: the parts of the tool force the engine reports apart, {series suffix: metric prefix}
    force_parts: dict[str, str]
    dt0: float  #: the stable step at the start [s]
    dt_limit: str  #: what limits it

    @classmethod
    def build(cls, scene, si, mesh, tool) -> Engine:
        """The engine of a cutting scene on ``mesh`` with the tool array ``tool``."""

    @property
    def time(self) -> float: ...

    @property
    def steps(self) -> int: ...

    @property
    def tool(self) -> np.ndarray:
        """The tool array now (:func:`solver.tool.tool_array`'s layout)."""

    def start_sample(self, travel: float) -> None:
        """A force sample begins with the tool ``travel`` [m] into the workpiece."""

    def advance(self, t_stop: float, n_steps: int) -> StepRecord:
        """At most ``n_steps`` steps, stopping at ``t_stop``."""

    def stable_step(self) -> float:
        """The stable step in force now [s]."""

    def tool_force(self, part: str = "") -> np.ndarray:
        """The tool force [N/m] summed over the steps so far: in all (``""``) or a part of
        ``force_parts``; Fx, Fy in all, then by face of the tool."""

    def max_penetration(self) -> float:
        """The deepest penetration of the tool since the sample started [m]."""

    def overloaded(self) -> int:
        """Far-field elements past their failure criterion."""

    def energies(self) -> dict[str, float]:
        """The energy terms [J/m] at a force sample, the energy error among them."""

    def check(self) -> None:
        """The engine's own checks at a force sample."""

    def frame(self, fields) -> dict:
        """A chip frame of the given fields (:func:`solver.outputs.frame`)."""

    def failed_elements(self) -> np.ndarray: ...

    def failed_cohesive(self) -> np.ndarray: ...

    def node_positions(self) -> tuple[np.ndarray, np.ndarray]: ...

    def node_alive(self) -> np.ndarray: ...

    def energy_error(self, energies: dict) -> float:
        """The run's energy error from the energies of the last sample."""

    def energy_warning(self, error: float, energies: dict, metrics: dict) -> str:
        """What an energy error above the warning threshold means for this engine."""

    def metrics(self, energies: dict) -> dict:
        """The engine's own metrics, from the energies of the last sample."""

    def arrays(self) -> dict:
        """Result.build["arrays"] entries of the engine: bytes and build seconds of its arrays."""


def build_engine(scene, si, mesh, tool) -> Engine:
    """The engine of ``scene.fidelity`` (:data:`solver.run.FIDELITIES`), imported when first asked for."""
    from .run import FIDELITIES

    fidelity = FIDELITIES.get(scene.fidelity)
    if fidelity is None or fidelity.engine is None:
        raise ValueError(f"fidelity {scene.fidelity!r} has no engine of the cutting scene")
    module, name = fidelity.engine.split(":")
    return getattr(import_module(module), name).build(scene, si, mesh, tool)
