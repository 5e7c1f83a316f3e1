"""The fibre in bending through the element (``fibre-bending``): moment-curvature to failure against beam theory.

In the cut, fibres above the cut plane are bent by the rake face and break in bending; the cutting scene
meshes a fibre with ``numerics.elements_across_fibre`` one-point quads across it (an assumed-strain bending
mode carries the strain gradient inside each, :mod:`solver.fem.quad`). This case bends one fibre of the
scene's preset, meshed as the scene meshes it, by equal and opposite end moments (quasi-static, moment
ramped over many periods of the first bending mode with mass-proportional damping) and compares with the
Euler-Bernoulli section of the same fibre law (reading B of the paper's Table 1, docs/model.md): along the
fibre, stress sigma = E' eps in tension to the brittle strength Xt, elastic in compression to Xc and then
perfectly plastic (to the compressive failure strain, not reached here), with E' = C11 - C12^2 / C22
(plane strain, free across the beam). Plane sections, no axial force, strain eps = eps0 + kappa y:

* elastic (kappa <= kappa_y = 2 eps_y / t, eps_y = Xc / E'):  M = E' t^3 kappa / 12;
* compression side flowing: the elastic part of the section has height L = t sqrt(kappa_y / kappa)
  (zero axial force), eps0 = -eps_y - kappa y_p with y_p = t/2 - L, and
  M = -Xc (y_p^2 - t^2/4) / 2 + E' [eps0 (t^2/4 - y_p^2) / 2 + kappa (t^3/8 - y_p^3) / 3];
* failure when the tensile face reaches Xt: kappa_f = (eps_y + eps_t)^2 / (2 eps_y t), eps_t = Xt / E'
  (when Xt > Xc; elastic-brittle kappa_f = 2 eps_t / t otherwise).

Measured: the moment applied (consistent nodal loads of the linear stress M y / I on the end faces, so
the axial force is zero), the curvature from the rotation of the sections at a quarter and three
quarters of the length (the node columns nearest), kappa = (theta(x3) - theta(x1)) / (x3 - x1), theta the least-squares slope of
u_x over the section's nodes; the last state before the first element fails gives the failure curvature and moment. The error is
the larger of the moment's largest relative error over the curve (kappa_f / 4 to the failure) and the
failure curvature's relative error; tolerance 15 %.

Overrides (``--set``): elements_across_fibre (default 3, the scene's), length_over_t (8, with the two caps), periods (200: the
ramp's length in periods of the first bending mode), damping (1: of critical at that mode), preset,
failure_at (edge, the scene's default; or centre), hourglass_follows_material (0, the scene's default; or 1:
the hourglass stiffness of a flowing element follows its secant ratio, :mod:`solver.fem.quad`).
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np

from solver import fem
from solver.fem.gridmesh import rect_mesh
from solver.fem.materials import C11, C12, C22, EPSFC, XT, material_table
from solver.fem.state import P_DAMP
from solver.fem.engine import hourglass_limit
from solver.mesh import FIBRE, MATRIX

CAP = MATRIX  # the material slot of the end caps (the fibre law without failure)
from solver.scene import Scene

from . import CaseResult, register
from .fem_cases import _keys, _opt

DEFAULTS = dict(elements_across_fibre=3.0, length_over_t=8.0, periods=200.0, damping=1.0)
TOLERANCE = 0.15


def section_moment(kappa: float, t: float, e_b: float, xc: float) -> float:
    """Moment per unit width of the fibre section at curvature kappa (module docstring) [N m / m]."""
    eps_y = xc / e_b
    k_y = 2.0 * eps_y / t
    if kappa <= k_y:
        return e_b * t ** 3 * kappa / 12.0
    L = t * math.sqrt(k_y / kappa)
    yp = 0.5 * t - L
    eps0 = -eps_y - kappa * yp
    plastic = -xc * (yp * yp - 0.25 * t * t) / 2.0
    elastic = e_b * (eps0 * (0.25 * t * t - yp * yp) / 2.0 + kappa * (t ** 3 / 8.0 - yp ** 3) / 3.0)
    return plastic + elastic


def failure_curvature(t: float, e_b: float, xc: float, xt: float) -> float:
    eps_y, eps_t = xc / e_b, xt / e_b
    if xt <= xc:
        return 2.0 * eps_t / t
    return (eps_y + eps_t) ** 2 / (2.0 * eps_y * t)


def _edge_loads(ys: np.ndarray, sigma) -> np.ndarray:
    """Consistent nodal loads of the traction sigma(y) (linear) on an edge with sorted node heights ys."""
    f = np.zeros(ys.size)
    for j in range(ys.size - 1):
        l = ys[j + 1] - ys[j]
        sa, sb = sigma(ys[j]), sigma(ys[j + 1])
        f[j] += l * (2 * sa + sb) / 6.0
        f[j + 1] += l * (sa + 2 * sb) / 6.0
    return f


def _slope(y: np.ndarray, u: np.ndarray) -> float:
    yc = y - y.mean()
    return float((yc * (u - u.mean())).sum() / (yc * yc).sum())


def bend(elements_across_fibre, length_over_t, periods, damping, preset="t800s-m21-2d", failure_at="edge",
         hourglass_follows_material=False):
    scene = Scene.model_validate({"materials": {"preset": preset}})
    si = scene.si()
    si.numerics = SimpleNamespace(cfl=0.9, mass_scaling=1.0)
    si.physics = SimpleNamespace(element_deletion=True, fibre_plasticity=True, cohesive_interface=False,
                                 fibre_failure_at=failure_at, ehm_failure=False,
                                 hourglass_follows_material=hourglass_follows_material)
    f = si.fibre
    t = float(si.fibre_diameter)
    ny = int(elements_across_fibre)
    h = t / ny
    nx = int(round(length_over_t * ny))
    Lb = nx * h
    mesh = rect_mesh(nx, ny, Lb, t, material=FIBRE, angle=0.0, y0=-0.5 * t)
    # the end caps (one fibre thickness at each end, where the moment is put in): the same fibre law that
    # cannot fail (in the matrix's slot), so that the load's introduction (its linear stress against the
    # section's plastic one) does not break the fibre there
    cx = mesh.x[mesh.quads].mean(axis=1)
    mesh.material[(cx < t) | (cx > Lb - t)] = CAP
    mid = np.abs(mesh.x - 0.5 * Lb) < 1e-9 * Lb
    mesh.fixed_x[mid] = True  # the mid section stays plane and in place (symmetry)
    centre = np.nonzero(mid)[0][np.argmin(np.abs(mesh.y[mid]))]
    mesh.fixed_y[centre] = True
    props = material_table(si, 1.0, True, False)
    props[CAP] = props[FIBRE]
    props[CAP, XT] = np.inf
    props[CAP, EPSFC] = np.inf
    state = fem.build_state(mesh, si, props=props, hourglass_ratio_max=hourglass_limit(ny))  # the cut's guard
    e_b = props[FIBRE, C11] - props[FIBRE, C12] ** 2 / props[FIBRE, C22]
    xc, xt = float(f.Xc), float(f.Xt)
    k_f = failure_curvature(t, e_b, xc, xt)
    m_f = section_moment(k_f, t, e_b, xc)
    # load: M y / I on the right end, its opposite on the left (zero resultant, zero axial force)
    inertia = t ** 3 / 12.0
    left, right = np.nonzero(mesh.x < 1e-9 * Lb)[0], np.nonzero(mesh.x > Lb * (1 - 1e-9))[0]
    unit = np.zeros(mesh.n_nodes)
    for ids, sgn in ((left, -1.0), (right, 1.0)):
        order = ids[np.argsort(mesh.y[ids])]
        unit[order] = sgn * _edge_loads(mesh.y[order], lambda y: y / inertia)
    cols = np.unique(mesh.x)
    x1 = cols[np.argmin(np.abs(cols - 0.25 * Lb))]  # the node columns nearest a quarter and three quarters
    q1 = np.nonzero(np.abs(mesh.x - x1) < 1e-9 * Lb)[0]
    q3 = np.nonzero(np.abs(mesh.x - (Lb - x1)) < 1e-9 * Lb)[0]
    x_q = float(mesh.x[q3][0] - mesh.x[q1][0])
    rho = float(props[FIBRE, 0])
    omega = 4.730 ** 2 / Lb ** 2 * math.sqrt(e_b * inertia / (rho * t))  # free-free first bending mode
    T = 2 * math.pi / omega
    state.params[P_DAMP] = 2 * damping * omega
    t_ramp = periods * T
    m_end = 1.5 * m_f
    state.fext = np.zeros((4, mesh.n_nodes))
    dt, _ = fem.stable_dt(state)
    curve = []
    failed = None
    chunk = 10
    while state.time < t_ramp:
        M = m_end * min(state.time / t_ramp, 1.0)
        state.fext[0] = M * unit
        rec = fem.advance(state, chunk, dt)
        if rec.status != "ok":
            raise RuntimeError(f"fibre-bending case unstable: {rec.finding}")
        ux = state.x - mesh.x
        kappa = (_slope(mesh.y[q3], ux[q3]) - _slope(mesh.y[q1], ux[q1])) / x_q
        if (state.alive == 0).any():
            # the state before the chunk in which the first element failed (a broken section moves the nodes
            # the curvature is read from)
            M0, k0 = curve[-1] if curve else (0.0, 0.0)
            failed = (M0, k0, int(np.nonzero(state.alive == 0)[0][0]), int(state.fail_mode[state.alive == 0][0]))
            break
        curve.append((M, kappa))
    curve = np.array(curve)
    sel = (curve[:, 1] >= 0.25 * k_f) & (curve[:, 1] <= (failed[1] if failed else curve[-1, 1]))
    ref = np.array([section_moment(k, t, e_b, xc) for k in curve[sel, 1]])
    m_err = float(np.max(np.abs(curve[sel, 0] - ref) / ref)) if sel.any() else math.inf
    k_err = abs(failed[1] - k_f) / k_f if failed else math.inf
    return {
        "failure_curvature_per_mm": failed[1] * 1e-3 if failed else math.nan,
        "failure_curvature_reference_per_mm": k_f * 1e-3,
        "failure_moment_N_mm_per_mm": failed[0] * 1e3 * 1e-3 if failed else math.nan,  # N m / m = N mm / mm
        "failure_moment_reference_N_mm_per_mm": m_f,
        "failure_mode": failed[3] if failed else 0,
        "yield_curvature_per_mm": 2 * xc / e_b / t * 1e-3,
        "moment_max_relative_error": m_err, "failure_curvature_relative_error": k_err,
        "error": max(m_err, k_err), "beam_modulus_GPa": e_b * 1e-9, "fibre_um": t * 1e6, "length_um": Lb * 1e6,
        "n_elements": int(mesh.n_elems), "steps": int(state.steps),
        "curve_kappa_per_mm": [float(k) * 1e-3 for k in curve[::max(len(curve) // 20, 1), 1]],
        "curve_moment_N_mm_per_mm": [float(m) for m in curve[::max(len(curve) // 20, 1), 0]],
    }


@register("fibre-bending", "one fibre meshed as in the cut, bent to failure: moment-curvature and failure curvature "
                           "vs beam theory of the fibre law (15 %)")
def case_fibre_bending(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    _keys(overrides, tuple(DEFAULTS) + ("preset", "failure_at", "hourglass_follows_material"))
    kw = {k: _opt(overrides, k, v) for k, v in DEFAULTS.items()}
    if not 2 <= kw["elements_across_fibre"] <= 8 or kw["elements_across_fibre"] != int(kw["elements_across_fibre"]):
        raise ValueError(f"elements_across_fibre = {kw['elements_across_fibre']:g}: allowed whole numbers 2 to 8 "
                         "(one element has no bending stiffness of its own; finer, the caps' corners crush)")
    for k in ("length_over_t", "periods"):
        if not kw[k] >= 2:
            raise ValueError(f"{k} = {kw[k]:g}: must be >= 2")
    fa = str(overrides.get("failure_at", "edge"))
    if fa not in ("edge", "centre"):
        raise ValueError(f"failure_at = {fa!r}: allowed edge or centre")
    hg = str(overrides.get("hourglass_follows_material", "0")).lower()
    if hg not in ("0", "1", "0.0", "1.0", "false", "true"):
        raise ValueError(f"hourglass_follows_material = {hg!r}: allowed 0 or 1 (false or true)")
    hg = hg in ("1", "1.0", "true")
    preset = str(overrides.get("preset", "t800s-m21-2d"))
    r = bend(**kw, preset=preset, failure_at=fa, hourglass_follows_material=hg)
    return CaseResult("fibre-bending", "failure curvature [1/mm] (error: the larger of its and the moment curve's)",
                      r["failure_curvature_per_mm"], r["failure_curvature_reference_per_mm"], r["error"], TOLERANCE,
                      time.perf_counter() - t0,
                      {**r, **kw, "preset": preset, "failure_at": fa, "hourglass_follows_material": hg})
