"""fibrecut's solver: numerics only (no web, no database).

    from solver import load_scene, run
    result = run(load_scene("seed-0deg-fem-quick", {"tool.rake_angle_deg": 15}))
    result.summary(); result.write_hdf5("run.h5")
"""

from . import cachestamp as _cachestamp

_cachestamp.check()  # before any compiled kernel is loaded: no stale cached code after an edit

from .result import Result  # noqa: E402
from .run import run  # noqa: E402
from .scene import Scene, SceneError, load_scene, scene_from_dict  # noqa: E402

__all__ = ["Result", "Scene", "SceneError", "load_scene", "run", "scene_from_dict"]
