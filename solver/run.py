"""``run(scene, progress=None) -> Result``: the solver's one face to the rest of fibrecut.

Dispatches on ``scene.fidelity`` through :data:`FIDELITIES`, the table of the implemented
fidelities: each names its runner, whether it needs numba kernels compiled (or loaded from the
cache) before the clock starts and, for a numerical fidelity, the engine the cutting scene drives
(:mod:`solver.engine`). The runners import their fidelity lazily, so an analytic run never imports
numba kernels. Any exception inside a fidelity ends the run as status ``failed`` with its
reason: a run never crashes its caller.
"""

from __future__ import annotations

import time
import traceback
from typing import Callable, NamedTuple

from .result import Result
from .scene import Scene

#: progress(fraction in [0, 1], message) -> False to ask the run to stop (status "cancelled").
Progress = Callable[[float, str], "bool | None"]


def _analytic(scene: Scene, progress: Progress | None) -> Result:
    from .analytic import run_analytic

    return run_analytic(scene)


def _cutting(scene: Scene, progress: Progress | None) -> Result:
    from .cutting import run_cutting

    return run_cutting(scene, progress=progress)


class Fidelity(NamedTuple):
    runner: Callable[[Scene, "Progress | None"], Result]
    compiled: bool  # numba kernels compiled or loaded (solver.warmup) before the run's clock starts
    engine: str | None = None  # "module:Class" of the cutting scene's engine (solver.engine.build_engine)
    mesher: str = "solver.mesher:build_mesh"  # "module:function" meshing the workpiece from scene.si()


#: every implemented fidelity
FIDELITIES: dict[str, Fidelity] = {
    "analytic": Fidelity(_analytic, compiled=False),
    "fem2d": Fidelity(_cutting, compiled=True, engine="solver.fem.engine:FemEngine"),
    "hybrid2d": Fidelity(_cutting, compiled=True, engine="solver.hybrid.engine:HybridEngine"),
    "fem3d": Fidelity(_cutting, compiled=True, engine="solver.fem3d.engine:Fem3dEngine",
                      mesher="solver.fem3d.strip3d:build_strip_mesh"),
    "hybrid3d": Fidelity(_cutting, compiled=True, engine="solver.hybrid.engine3d:Hybrid3dEngine",
                         mesher="solver.fem3d.strip3d:build_strip_mesh"),
}


def run(scene: Scene, progress: Progress | None = None) -> Result:
    fidelity = FIDELITIES.get(scene.fidelity)
    compile_s = 0.0
    if fidelity is not None and fidelity.compiled:  # kernels compiled or loaded before the clock starts
        from .warmup import compile_kernels

        compile_s = compile_kernels(scene.fidelity)
    t0 = time.perf_counter()
    try:
        if fidelity is None:  # the scene schema lists only known fidelities; keep a clear message anyway
            raise ValueError(f"fidelity {scene.fidelity!r} is not implemented")
        result = fidelity.runner(scene, progress)
    except Exception as exc:  # noqa: BLE001 - a run reports, it does not crash its caller
        result = Result(scene=scene, status="failed",
                        diagnosis={"check": "exception", "what": f"{type(exc).__name__}: {exc}",
                                   "traceback": traceback.format_exc(limit=8)})
        result.warnings.append(f"run failed: {type(exc).__name__}: {exc}")
    if not result.wall_time_s:
        result.wall_time_s = time.perf_counter() - t0
    result.metrics.setdefault("material_removal_rate_mm2_s", scene.cut.depth_um * 1e-3 * scene.cut.speed_mm_s)
    result.metrics["compile_time_s"] = compile_s  # apart from wall_time_s (solver.warmup)
    return result
