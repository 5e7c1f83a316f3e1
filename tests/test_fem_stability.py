"""The stability guard: deliberately unstable inputs end ``unstable`` with a diagnosis, never NaN.

* a CFL factor of 5 (the explicit scheme is stable only below 1);
* a cohesive penalty of 1e20 Pa/m with its time-step limit switched off (ignore_cohesive_dt);
* an unstabilised bending mode (one element across a bending strip: the hourglass check);
and in every case no NaN/Inf leaks into the state or the energies.
"""

import math

import numpy as np

from solver import fem
from solver.fem.gridmesh import rect_mesh, strip_mesh
from solver.scene import Scene


def _strip_state(cfl=0.5, penalty=None, **kw):
    si = Scene().si()
    si.numerics.cfl = cfl
    if penalty is not None:
        si.interface.K = penalty
    mesh = strip_mesh(12, 2, 24e-6, 7.5e-6, 5e-6, across_fibre=4, across_matrix=2)
    mesh.fixed_x[mesh.x < 1e-12] = True
    mesh.fixed_y[mesh.x < 1e-12] = True
    state = fem.build_state(mesh, si, **kw)
    # a bending + stretching velocity field
    state.vx[:] = 2.0 * state.X0 / 24e-6
    state.vy[:] = 5.0 * (state.X0 / 24e-6) ** 2
    return state


def _assert_finite(state):
    for name in ("x", "y", "vx", "vy", "stress", "eint", "ehg", "dmg"):
        assert np.isfinite(getattr(state, name)).all(), name
    for k, v in state.energies.items():
        assert math.isfinite(v), k


def _assert_diagnosis(rec, checks):
    assert rec.status == "unstable"
    d = rec.finding
    assert d["check"] in checks, d
    for key in ("step", "time_s", "what", "change", "material"):
        assert key in d, (key, d)
    assert d["material"] in ("fibre", "matrix", "ehm"), d
    assert d["element"] is not None and d["element"] >= 0, d
    assert d["step"] >= 0 and d["time_s"] >= 0


def test_stable_reference_runs_ok():
    state = _strip_state()
    rec = fem.advance(state, 2000)
    assert rec.status == "ok", rec.finding
    assert rec.steps == 2000
    _assert_finite(state)
    assert state.energies["energy_error"] < 1e-3


def test_cfl_5_ends_unstable_with_diagnosis():
    state = _strip_state(cfl=5.0)
    rec = fem.advance(state, 5000)
    _assert_diagnosis(rec, ("nan", "inverted", "dt_collapse", "energy"))
    assert rec.steps < 5000
    _assert_finite(state)
    again = fem.advance(state, 10)  # an unstable state is not advanced further
    assert again.steps == 0 and again.status == "unstable"


def test_stiff_cohesive_penalty_without_its_limit_ends_unstable():
    state = _strip_state(penalty=1e20, ignore_cohesive_dt=True)
    dt, limit = fem.stable_dt(state)
    assert "element" in limit  # the cohesive limit is switched off
    rec = fem.advance(state, 5000)
    _assert_diagnosis(rec, ("nan", "inverted", "dt_collapse", "energy"))
    _assert_finite(state)


def test_stiff_cohesive_penalty_with_its_limit_is_stable():
    state = _strip_state(penalty=1e20)
    dt, limit = fem.stable_dt(state)
    assert limit.startswith("cohesive")
    rec = fem.advance(state, 300)
    assert rec.status == "ok", rec.finding
    _assert_finite(state)


def test_hourglass_check_fires_on_one_element_across_a_bending_strip():
    si = Scene().si()
    si.matrix.sigma_u = 1e12
    mesh = rect_mesh(20, 1, 200e-6, 10e-6, material=1)
    mesh.fixed_x[mesh.x < 1e-12] = True
    mesh.fixed_y[mesh.x < 1e-12] = True
    state = fem.build_state(mesh, si)
    state.vy[:] = 30.0 * (state.X0 / 200e-6) ** 2
    rec = fem.advance(state, 20000)
    _assert_diagnosis(rec, ("hourglass",))
    assert rec.finding["hourglass_ratio"] > 0.1
    _assert_finite(state)
