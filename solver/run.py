"""``run(scene, progress=None) -> Result``: the solver's one face to the rest of fibrecut.

Dispatches on ``scene.fidelity``. Numerical fidelities are imported lazily, so an
analytic run never imports numba kernels. Any exception inside a fidelity ends the run
as status ``failed`` with its reason: a run never crashes its caller.
"""

from __future__ import annotations

import time
import traceback
from typing import Callable

from .result import Result
from .scene import Scene

#: progress(fraction in [0, 1], message) -> False to ask the run to stop (status "cancelled").
Progress = Callable[[float, str], "bool | None"]


def run(scene: Scene, progress: Progress | None = None) -> Result:
    compile_s = 0.0
    if scene.fidelity in ("fem2d", "hybrid2d"):  # kernels compiled or loaded before the clock starts
        from .warmup import compile_kernels

        compile_s = compile_kernels(scene.fidelity)
    t0 = time.perf_counter()
    try:
        if scene.fidelity == "analytic":
            from .analytic import run_analytic

            result = run_analytic(scene)
        elif scene.fidelity in ("fem2d", "hybrid2d"):
            from .cutting import run_cutting

            result = run_cutting(scene, progress=progress)
        else:  # hybrid3d is rejected by the schema; keep a clear message anyway
            raise ValueError(f"fidelity {scene.fidelity!r} is not implemented")
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
