"""fibrecut's solver: numerics only (no web, no database).

    from solver import load_scene, run
    result = run(load_scene("seed-0deg-fem-quick", {"tool.rake_angle_deg": 15}))
    result.summary(); result.write_hdf5("run.h5")
"""

from .result import Result
from .run import run
from .scene import Scene, SceneError, load_scene, scene_from_dict

__all__ = ["Result", "Scene", "SceneError", "load_scene", "run", "scene_from_dict"]
