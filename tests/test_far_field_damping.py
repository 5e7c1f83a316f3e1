"""The absorbing far field (``workpiece.far_field_damping_per_us``): mass-proportional damping on the nodes only
EHM elements hold.

* The far field's nodes are those no fibre or matrix element touches: the line the EHM shares with the micro
  zone stays undamped.
* A damped block translating freely loses its velocity as exp(-c t) (c dt = 1e-3 here) and the energy
  balance books the loss as the damping's dissipation.
* A scene's value reaches exactly the far field's nodes of the cutting engine, held below 0.5 / dt.
"""

import math

import numpy as np
import pytest

from solver import fem, load_scene
from solver.fem.engine import FAR_FIELD_DAMPING_DT_MAX, FemEngine
from solver.fem.gridmesh import rect_mesh
from solver.mesh import EHM, MATRIX
from solver.mesher import build_mesh
from solver.scene import Scene, SceneError
from solver.tool import tool_array


def test_the_far_field_is_the_nodes_only_ehm_elements_hold():
    mesh = rect_mesh(4, 4, 40e-6, 40e-6, material=EHM)
    top = mesh.y[mesh.quads].mean(axis=1) > 30e-6  # the top row of elements becomes matrix
    mesh.material[top] = MATRIX
    far = mesh.far_field_nodes()
    assert far.sum() == 15  # 5 x 5 nodes, the top two rows of nodes touch a matrix element
    assert np.all(mesh.y[far] < 20e-6 + 1e-12) and np.all(mesh.y[~far] > 30e-6 - 1e-12)


def test_a_damped_translation_decays_as_exp_minus_ct_and_the_balance_books_it():
    si = Scene().si()
    mesh = rect_mesh(6, 3, 60e-6, 30e-6, material=EHM)
    state = fem.build_state(mesh, si)
    dt = 0.5 * fem.stable_dt(state)[0]
    c = 1e-3 / dt
    state.vx[:] = 2.0
    state.vy[:] = -1.0
    state.cnode[:] = c
    ke0 = 0.5 * float(np.sum(state.mass * (state.vx ** 2 + state.vy ** 2)))
    n = 1000
    rec = fem.advance(state, n, dt=dt)
    assert rec.status == "ok", rec.finding
    # a rigid translation (no internal force): the nodes keep one velocity, exp(-c t) of the first
    assert np.ptp(state.vx) <= 1e-8 and np.ptp(state.vy) <= 1e-8  # round-off of the positions
    assert state.vx[0] == pytest.approx(2.0 * math.exp(-c * n * dt), rel=2e-3)
    assert state.vy[0] == pytest.approx(-1.0 * math.exp(-c * n * dt), rel=2e-3)
    en = state.energies
    assert en["viscous"] == pytest.approx(ke0 - en["kinetic"], rel=2e-3)
    assert en["energy_error"] < 2e-3, en


def _engine_state(damping_per_us, **over):
    scene = load_scene("seed-0deg-fem-quick", {"cut.length_um": 10, "workpiece.far_field_damping_per_us": damping_per_us,
                                               **over})
    si = scene.si()
    mesh = build_mesh(si)
    parts = FemEngine.parts(scene, si, mesh, tool_array(si))
    return mesh, parts


def test_the_scene_damps_exactly_the_far_field_of_the_cutting_engine():
    mesh, parts = _engine_state(10.0)
    state = parts["state"]
    far = mesh.far_field_nodes()
    assert far.any() and (~far).any()
    assert np.all(state.cnode[far] == 1e7) and np.all(state.cnode[~far] == 0.0)
    assert state.far_field == {"nodes": int(far.sum()), "per_us": 10.0, "asked_per_us": 10.0, "capped": False}
    _, off = _engine_state(0.0)
    assert off["state"].far_field is None and not off["state"].cnode.any()


def test_damping_too_strong_for_the_step_is_held_below_half_over_dt():
    mesh, parts = _engine_state(1000.0, **{"numerics.mass_scaling": 1e6})
    state = parts["state"]
    c = state.cnode[mesh.far_field_nodes()]
    assert state.far_field["capped"] and np.all(c == pytest.approx(FAR_FIELD_DAMPING_DT_MAX / parts["dt0"]))


def test_the_3d_strip_refuses_the_field():
    with pytest.raises(SceneError, match="far_field_damping_per_us"):
        load_scene("seed-0deg-fem3d-quick", {"workpiece.far_field_damping_per_us": 5})
