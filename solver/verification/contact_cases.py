"""Verification of the rigid tool's contact (``fibrecut verify tool-hertz``) against Hertz's solution.

* ``tool-hertz``  the tool's rounded cutting edge (a rigid cylinder of radius R, the tool's own exact
  geometry of :mod:`solver.tool` and penalty contact of :func:`solver.contact.tool_contact`, frictionless)
  pressed quasi-statically into an elastic block in plane strain. Hertz's line contact (Johnson,
  Contact Mechanics, 1985, sec. 4.3, eqs. 4.43-4.45) for a rigid cylinder on an elastic half-space:

      a^2 = 4 P R / (pi E*),   p(x) = p0 sqrt(1 - x^2 / a^2),   p0 = 2 P / (pi a),   E* = E / (1 - nu^2),

  P the load per unit length. The contact half-width is read from the nodal contact forces f_i by
  their second moment about the edge's centre line, a^2 = 4 sum f_i (x_i - x_c)^2 / sum f_i, which is
  exact for the Hertz pressure (int x^2 p dx = P a^2 / 4) and does not depend on where the last
  node in contact happens to fall. The error is |a - a_H(P)| / a_H(P) at the measured load.

  The penalty contact is a spring of stiffness k_i = alpha f m_i / dt^2 on every node in contact
  (alpha = :data:`solver.contact.TOOL_ALPHA`, f = ``factor``, the scene's
  ``numerics.contact_stiffness_factor``): in series with the body it makes the edge softer than rigid,
  so the contact is wider than Hertz's. Per unit area that spring is about alpha f rho c_p^2 / (1.6 h)
  (dt = 0.9 h / c_p, a surface node carrying half an element's mass); the body's own contact compliance
  is about a / E*. Their ratio, ~ 1.6 (E* / (rho c_p^2)) (h / a) / (alpha f), is what the case
  measures: the error falls with alpha f and with a / h (measured with
  ``fibrecut verify tool-hertz --set ...``; the figures at :data:`solver.contact.TOOL_ALPHA`).

Block: width ``width_over_a`` x a, height ``depth_over_a`` x a (a half-space to within about 1 % in a
at 8 a; Johnson sec. 5.9), bottom fixed, sides on rollers, square elements of size h = a / ``a_over_h``
(a the intended half-width). The edge's radius is ``radius_over_a`` x a (a / R small: Hertz's
assumption); the tool's clearance face is turned up to 30 degrees so that only the arc touches. The
edge is driven down along a smooth (1 - cos) path over ``periods`` periods of the block's first shear
mode and held for ``hold`` more with mass-proportional damping (``damping`` of critical at that mode),
which leaves the static equilibrium unchanged once the block is at rest.

Overrides (``--set``): a_over_h, factor, depth_over_a, width_over_a, radius_over_a, periods, hold,
damping, cfl.
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np

from solver import fem
from solver.contact import TOOL_ALPHA, contact_stiffness
from solver.fem.gridmesh import rect_mesh
from solver.fem.state import P_DAMP
from solver.tool import tool_array

from . import CaseResult, _settings, register
from .fem_cases import _si

EPOXY = dict(E=2.96e9, nu=0.4, rho=1280.0)  # the seed preset's matrix: isotropic, elastic here
#: the case's settings (``--set``) and their defaults
DEFAULTS = dict(a_over_h=8.0, factor=1.0, depth_over_a=8.0, width_over_a=16.0, radius_over_a=20.0, periods=4.0,
                hold=4.0, damping=1.0, cfl=0.9)


def hertz_half_width(P: float, R: float, E: float, nu: float) -> float:
    """Hertz's contact half-width of a rigid cylinder on an elastic half-space, plane strain [m]."""
    return math.sqrt(4.0 * P * R * (1.0 - nu * nu) / (math.pi * E))


def edge_tool(xc: float, y_low: float, R: float, clearance_deg: float = 30.0) -> np.ndarray:
    """The contract's tool array (:func:`solver.tool.tool_array`) for an edge of radius R whose lowest
    point is (xc, y_low), at rest, with a vertical rake face."""
    edge = SimpleNamespace(rake=0.0, clearance=math.radians(clearance_deg), edge_radius=R, speed=0.0,
                           numerics=SimpleNamespace(speed_scaling=1.0), depth=-y_low)
    return tool_array(edge, x_start=xc)


def press(a_over_h, factor, depth_over_a, width_over_a, radius_over_a, periods, hold, damping, cfl, a_target=10e-6):
    """Press the edge into the block; returns the measured load, half-width and indicators (SI)."""
    m = EPOXY
    h = a_target / a_over_h
    nx, ny = int(round(width_over_a * a_over_h)), int(round(depth_over_a * a_over_h))
    W, H, R = nx * h, ny * h, radius_over_a * a_target
    mesh = rect_mesh(nx, ny, W, H, material=1, y0=-H)
    mesh.fixed_x[(mesh.x < 1e-9 * W) | (mesh.x > W * (1 - 1e-9))] = True
    bottom = mesh.y < -H * (1 - 1e-9)
    mesh.fixed_x[bottom] = True
    mesh.fixed_y[bottom] = True
    si = _si(cfl, E=m["E"], nu=m["nu"], rho=m["rho"], sigma_u=1e15)
    xc = 0.5 * W + 0.5 * h  # between two nodes: no node sits on the centre line
    tool = edge_tool(xc, 0.0, R)
    state = fem.build_state(mesh, si, tool=tool)
    dt0, _ = fem.stable_dt(state)
    k_pen = contact_stiffness(float(state.mass[state.mass > 0].min()), dt0, factor, TOOL_ALPHA)  # the cutting scenes' rule
    dt, limit = fem.stable_dt(state, k_pen)
    # the approach that gives about a_target on a layer of depth H (Johnson eq. 5.39 with the layer's
    # depth as the reference): delta = (a^2 / 4R) (2 ln(2H/a) - 1); the measurement uses whatever a results
    delta = a_target ** 2 / (4 * R) * (2 * math.log(2 * H / a_target) - 1)
    G = m["E"] / (2 * (1 + m["nu"]))
    c_s = math.sqrt(G / m["rho"])
    omega0 = math.pi * c_s / (2 * H)
    T = 2 * math.pi / omega0
    t_load, t_end = periods * T, (periods + hold) * T
    state.params[P_DAMP] = 2 * damping * omega0  # mass-proportional damping
    chunk = 50
    while state.time < t_end:
        t = state.time
        # depth along (1 - cos): the tool's velocity over the next chunk, then at rest
        state.tool[3] = -0.5 * delta * (math.pi / t_load) * math.sin(math.pi * t / t_load) if t < t_load else 0.0
        rec = fem.advance(state, chunk, dt, k_pen=k_pen, mu=0.0, t_stop=t_end)
        if rec.status != "ok":
            raise RuntimeError(f"Hertz case unstable: {rec.finding}")
    f = -state.fcy  # the tool's push on each node is down; the load on the tool is its opposite
    P = float(f.sum())
    if not P > 0:
        raise RuntimeError("Hertz case: the edge carries no load (it never touched the block)")
    a2 = 4.0 * float((f * (state.x - state.tool[0]) ** 2).sum()) / P
    a_meas = math.sqrt(a2)
    a_ref = hertz_half_width(P, R, m["E"], m["nu"])
    e = state.energies
    return {"P_N_per_m": P, "a_m": a_meas, "a_hertz_m": a_ref, "error": abs(a_meas - a_ref) / a_ref,
            "p0_Pa": float(f.max() / h), "p0_hertz_Pa": 2 * P / (math.pi * a_ref),
            "nodes_in_contact": int((f > 0).sum()), "hertz_a_over_h": a_ref / h,
            "max_penetration_fraction_of_element": float(state.tool_out[2] / h),
            "approach_m": delta, "radius_m": R, "element_size_m": h, "n_elements": mesh.n_elems,
            "steps": int(state.steps), "dt_s": dt, "dt_limited_by": limit,
            "kinetic_over_internal": e["kinetic"] / max(e["internal"], 1e-300), "energy_error": e["energy_error"]}


@register("tool-hertz", "tool contact: the rigid edge pressed into an elastic block vs Hertz's contact half-width (5 %)")
def case_hertz(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    kw = _settings(overrides, DEFAULTS, positive=("a_over_h", "factor", "depth_over_a", "width_over_a", "radius_over_a",
                                                  "periods"))
    if not 1.0 <= kw["a_over_h"] <= 64.0:
        raise ValueError(f"a_over_h = {kw['a_over_h']:g}: allowed 1 to 64 elements across the contact half-width")
    r = press(**kw)
    return CaseResult("tool-hertz", "contact half-width a [m]", r["a_m"], r["a_hertz_m"], r["error"], 0.05,
                      time.perf_counter() - t0, {**r, **kw})
