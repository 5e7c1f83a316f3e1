"""Explicit 2D plane-strain FEM engine.

Use::

    from solver import fem
    state = fem.build_state(mesh, scene.si(), tool=tool)   # SoA arrays, SI
    dt, limited_by = fem.stable_dt(state)                   # CFL x critical step, and why
    rec = fem.advance(state, n_steps, dt, k_pen=k, mu=0.3)  # compiled steps; rec.status, rec.finding
    state.energies                                          # energy balance dict (energy_error, ...)
    out = fem.run(state, t_end, progress=cb)                # chunked driver with sampled histories

Pieces (one idea per file): :mod:`.state` (build), :mod:`.materials`, :mod:`.quad`,
:mod:`.cohesive`, :mod:`.timestep`, :mod:`.energy`, :mod:`.guard`, :mod:`.loop`,
:mod:`.gridmesh` (small structured meshes for verification and benchmarks).
"""

from .energy import energies
from .guard import diagnosis
from .loop import StepRecord, advance, run
from .materials import MODE_NAMES
from .state import FemState, build_state
from .timestep import stable_dt

__all__ = ["FemState", "StepRecord", "MODE_NAMES", "advance", "build_state", "diagnosis", "energies", "run",
           "stable_dt"]
