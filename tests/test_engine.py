"""The engine interface of the cutting scene (solver.engine): the fidelity table names each numerical
fidelity's engine, both engines have every method the scene drives, and a scene that converts no
element runs on classic FEM."""

from __future__ import annotations

import pytest

from solver.engine import Engine, build_engine
from solver.mesher import build_mesh
from solver.run import FIDELITIES
from solver.scene import load_scene
from solver.tool import tool_array

TINY = {"cut.length_um": 4.0, "cut.depth_um": 30.0, "tool.edge_radius_um": 5.0, "workpiece.height_um": 60.0,
        "workpiece.micro_zone_depth_um": 15.0, "numerics.n_force_samples": 20, "numerics.n_frames": 0}


def _engine(name: str, **over):
    scene = load_scene(name, {**TINY, **over})
    si = scene.si()
    return build_engine(scene, si, build_mesh(si), tool_array(si))


def test_the_fidelity_table_names_the_engines_and_what_needs_compiling():
    assert FIDELITIES["analytic"].engine is None and not FIDELITIES["analytic"].compiled
    assert FIDELITIES["fem2d"].compiled and FIDELITIES["hybrid2d"].compiled
    assert FIDELITIES["hybrid3d"].compiled and FIDELITIES["hybrid3d"].engine == "solver.hybrid.engine3d:Hybrid3dEngine"
    assert FIDELITIES["hybrid3d"].mesher == FIDELITIES["fem3d"].mesher  # the same 3D strip


@pytest.mark.parametrize("name, cls, parts", [("seed-0deg-fem-quick", "FemEngine", {}),
                                              ("seed-0deg-hybrid-d01-quick", "HybridEngine", {"_particles": "sph"})])
def test_each_engine_has_the_interface(name, cls, parts):
    engine = _engine(name)
    assert type(engine).__name__ == cls and isinstance(engine, Engine)
    assert engine.force_parts == parts
    assert engine.steps == 0 and engine.time == 0.0 and engine.dt0 > 0
    assert engine.tool_force().shape == (8,)
    for p in parts:
        assert engine.tool_force(p).shape == (8,)


def test_a_hybrid_scene_without_element_deletion_runs_on_classic_fem():
    engine = _engine("seed-0deg-hybrid-d01-quick", **{"physics.element_deletion": False})
    assert type(engine).__name__ == "FemEngine" and "solver.sph" not in engine.modules


def test_an_analytic_scene_has_no_engine():
    scene = load_scene("seed-0deg-fem-quick", {"fidelity": "analytic"})
    with pytest.raises(ValueError, match="no engine"):
        build_engine(scene, None, None, None)
