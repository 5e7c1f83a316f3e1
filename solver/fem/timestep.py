"""The stable time step of the explicit central-difference scheme (docs/model.md, "Numerics").

dt = CFL x min(dt_elements, dt_cohesive, dt_contact), each the critical step at CFL 1:

* element e: dt_e = A_e / (d_max,e c_max,e), the current area over the longer current
  diagonal (recomputed as elements distort) over the fastest wave speed of its material,
  c_max = sqrt(lambda_max(C_Mandel) / rho), the stiffest direction (the fibre direction for a
  fibre at any angle; :func:`solver.fem.materials.max_wave_speed`). For a square of side h this
  is h / (sqrt 2 c), the exact limit of its breathing mode.
* cohesive: a spring k = K L0/2 between two nodal masses, dt <= 2 / sqrt(k (1/m_a + 1/m_b))
  (Belytschko, Liu & Moran 2014, 6.3); left out when the state was built with
  ``ignore_cohesive_dt`` (to provoke the instability it guards against).
* contact: a node of mass m on the penalty spring k_pen: dt <= 2 sqrt(m_min / k_pen).
"""

from __future__ import annotations

import math

import numba

from .materials import CMAX
from ..mesh import MATERIAL_NAMES

LIMITS = ("element", "cohesive", "contact")


@numba.njit(cache=True, inline="always")
def area_and_diagonal(quads, px, py, e):
    """Current area A_e of quad e (half the cross product of its diagonals) and its longer
    diagonal d_max,e: the two lengths of the element's critical step A / (d_max c_max)."""
    n0, n1, n2, n3 = quads[e, 0], quads[e, 1], quads[e, 2], quads[e, 3]
    ac = 0.5 * ((px[n2] - px[n0]) * (py[n3] - py[n1]) - (px[n3] - px[n1]) * (py[n2] - py[n0]))
    d1 = (px[n2] - px[n0]) ** 2 + (py[n2] - py[n0]) ** 2
    d2 = (px[n3] - px[n1]) ** 2 + (py[n3] - py[n1]) ** 2
    return ac, math.sqrt(max(d1, d2))


@numba.njit(cache=True)
def element_dt(quads, px, py, mat, props, alive):
    """(min over living elements of A / (d_max c_max), its element id, number inverted)."""
    best = 1e300
    ib = -1
    ninv = 0
    for e in range(quads.shape[0]):
        if alive[e] == 0:
            continue
        ac, dmax = area_and_diagonal(quads, px, py, e)
        if ac <= 0.0:
            ninv += 1
            continue
        dte = ac / (dmax * props[mat[e], CMAX])
        if dte < best:
            best = dte
            ib = e
    return best, ib, ninv


def critical_dt(state, k_pen: float | None = None):
    """The critical step at CFL 1 and what sets it: (dt, kind, id) with kind in LIMITS."""
    dt, ie, _ = element_dt(state.quads, state.x, state.y, state.mat, state.props, state.alive)
    kind, ident = "element", ie
    if state.params[2] == 0.0 and state.dt_cohesive < dt:
        dt, kind, ident = state.dt_cohesive, "cohesive", state.dt_cohesive_id
    k = state.k_pen if k_pen is None else k_pen
    if state.has_tool and k > 0:
        dtc = 2.0 * math.sqrt(float(state.params[7]) / k)
        if dtc < dt:
            dt, kind, ident = dtc, "contact", -1
    return float(dt), kind, int(ident)


def describe_limit(state, kind: str, ident: int) -> str:
    if kind == "element" and ident >= 0:
        m = int(state.mat[ident])
        what = "fibre-direction wave speed" if m == 0 else ("fastest wave speed (EHM, fibre direction)" if m == 2 else "P-wave speed")
        return f"element {ident} ({MATERIAL_NAMES[m]}): {what} {state.props[m, CMAX]:.4g} m/s over its size"
    if kind == "cohesive":
        return f"cohesive element {ident}: penalty {state.cprops[0]:.3g} Pa/m on its nodal masses"
    if kind == "contact":
        return "tool contact penalty on the smallest nodal mass"
    return kind


def stable_dt(state, k_pen: float | None = None):
    """(dt, what limited it): CFL x the critical step of the current configuration [s].

    ``k_pen`` (N/m per m width) adds the contact limit; by default the state's ``k_pen``
    (set by the last :func:`solver.fem.advance`). The text names the element (or cohesive
    element) and its material.
    """
    dt, kind, ident = critical_dt(state, k_pen)
    if not math.isfinite(dt) or dt >= 1e299:
        raise ValueError("no living element: the stable step is undefined")
    return float(state.params[0]) * dt, describe_limit(state, kind, ident)
