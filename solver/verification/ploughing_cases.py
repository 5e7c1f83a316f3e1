"""The surface under the edge (``fibrecut verify tool-ploughing``): the rounded edge sliding at a fixed
interference over an intact, elastic orthotropic block, against the analytic model's bouncing term.

The analytic model (:mod:`solver.analytic`, docs/analytic-model.md) puts most of the thrust of a cut on the
clearance face: the surface pressed down by the edge springs back by delta_b behind it and presses on the
face with the plane-strain contact stiffness (pi/4) E_n (Zhang, Zhang & Wang 2001), E_n the ply's modulus
normal to the surface (E2 with the fibres along the cut, E1 across it). For an elastic block, nothing is
crushed (the hardness in series is infinite) and the whole interference delta springs back, so the term reads

    N = (pi/4) E_n delta,    F_t,clearance = N cos(gamma)   (frictionless),

gamma the clearance angle. This case measures the same force with the engine: the workpiece's far-field
material (the EHM of the scene's preset: orthotropic, rule of mixtures, elastic; :mod:`solver.fem.materials`)
as a block of square elements, bottom fixed, sides on rollers; the scene's tool (edge radius, rake and
clearance angles) with its lowest point on the surface is pressed down to ``interference_um`` along a smooth
(1 - cos) path over ``periods`` periods of the block's first shear mode, held for ``hold`` periods, then slid
along the cut (-x, the clearance face trailing) by ``slide_over_c`` clearance-contact lengths
c = delta / tan(gamma) at ``mach`` times the block's shear wave speed, frictionless; mass-proportional damping
at ``damping`` of critical for the first mode keeps it quasi-static (its drag on the sliding field is about
pi mach c / H of the elastic stress). The clearance face's force is the mean over the second half of the
slide. Frictionless and elastic, the sliding state is the static indentation by the same profile, so the
static force at the end of the hold is reported beside it as a check of the slide's quasi-statics.

With the fibres across the surface (``fibre_angle_deg`` 90) the edge compresses the block along its fibres,
and an aligned elastic ply loses stability in shear when that stress reaches about its shear modulus G12 (the
shear mode of fibre microbuckling, Rosen 1965; Budiansky & Fleck 1993, J. Mech. Phys. Solids 41:183, whose
kinking stress G12 / (1 + phi / gamma_y) is G12 for perfectly aligned fibres): the surface kinks and its
elements collapse. The case then records the most compressive fibre-direction stress (2nd Piola-Kirchhoff
in the reference fibre axes) reached before the largest element shear strain passed KINK_SHEAR, the
interference then, and the engine's diagnosis, and fails (error 1): no elastic spring-back is measured.

The comparison tests the analytic model as much as the engine: plane-strain indentation has no
half-space limit (the force at a given interference grows slowly as the block gets shallower, Johnson,
Contact Mechanics, 1985, sec. 5.9), so the block's depth ``depth_over_c`` x c is part of the case's
definition, and the tolerance (25 %) is that of a one-constant contact spring. The edge's own thrust is
reported beside the analytic pressing term's elastic part.

Overrides (``--set``): interference_um, element_size_um, fibre_angle_deg, depth_over_c, width_over_c,
slide_over_c, periods, hold, mach, damping, cfl, preset.
"""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np

from solver import fem
from solver.analytic import normal_modulus, ply_properties
from solver.contact import TOOL_ALPHA, contact_stiffness
from solver.fem.engine import hourglass_limit
from solver.fem.gridmesh import rect_mesh
from solver.fem.state import P_DAMP, TOOL_FORCE_ROWS
from solver.mesh import EHM
from solver.scene import Scene
from solver.tool import tool_array

from . import CaseResult, register
from .fem_cases import _keys, _opt

DEFAULTS = dict(interference_um=3.0, element_size_um=1.5, fibre_angle_deg=0.0, depth_over_c=4.0, width_over_c=7.0,
                slide_over_c=1.0, periods=3.0, hold=2.0, mach=0.01, damping=1.0, cfl=0.9)
TOLERANCE = 0.25
#: the element shear strain (engineering) past which the surface counts as kinked: the elastic slide stays below
#: 0.04 (0.3-2 um of interference across the fibres), a kinking element passes 0.2 within a few nanoseconds
KINK_SHEAR = 0.1


def _si(preset: str, fibre_angle_deg: float, cfl: float):
    si = Scene.model_validate({"materials": {"preset": preset}, "workpiece": {"fibre_angle_deg": fibre_angle_deg}}).si()
    si.numerics = SimpleNamespace(cfl=cfl, mass_scaling=1.0)
    si.physics = SimpleNamespace(element_deletion=False, fibre_plasticity=False, cohesive_interface=False,
                                 ehm_failure=False)
    return si


def _face_forces(state, forces0, n_steps):
    """Mean tool force over the last n_steps, [Fx, Fy, rake Fx, Fy, edge Fx, Fy, clearance Fx, Fy] in N/m."""
    return (state.tool_out[TOOL_FORCE_ROWS] - forces0) / max(n_steps, 1)


def fibre_stress(state) -> np.ndarray:
    """Each element's 2nd Piola-Kirchhoff stress along its reference fibre axis (c, s) [Pa]:
    S_ff = S_xx c^2 + S_yy s^2 + 2 S_xy s c (the 11 row of the element's rotation into its material frame,
    :func:`solver.fem.materials.strain_to_material_frame`, here over all elements at once)."""
    c, s, S = state.cphi, state.sphi, state.stress
    return S[:, 0] * c * c + S[:, 1] * s * s + 2.0 * S[:, 2] * s * c


def plough(interference_um, element_size_um, fibre_angle_deg, depth_over_c, width_over_c, slide_over_c, periods, hold,
           mach, damping, cfl, preset="t800s-m21-2d"):
    """Press the edge into the block, slide it; returns the clearance face's force and indicators (SI), or, when
    the block's surface collapses, the engine's diagnosis and the kink's onset (``collapsed``, module docstring)."""
    si = _si(preset, fibre_angle_deg, cfl)
    n_across = int(Scene().numerics.elements_across_fibre)
    delta, h = interference_um * 1e-6, element_size_um * 1e-6
    gamma, R = float(si.clearance), float(si.edge_radius)
    c = delta / math.tan(gamma)  # the clearance face's contact length
    nx, ny = int(math.ceil(width_over_c * c / h)), int(math.ceil(depth_over_c * c / h))
    W, H = nx * h, ny * h
    mesh = rect_mesh(nx, ny, W, H, material=EHM, angle=math.radians(fibre_angle_deg), y0=-H)
    mesh.fixed_x[(mesh.x < 1e-9 * W) | (mesh.x > W * (1 - 1e-9))] = True
    bottom = mesh.y < -H * (1 - 1e-9)
    mesh.fixed_x[bottom] = True
    mesh.fixed_y[bottom] = True
    # the tool: lowest point on the surface, placed so that after the slide the edge stands at 0.4 W
    slide = slide_over_c * c
    xc = 0.4 * W + slide + 0.5 * h
    edge = SimpleNamespace(rake=si.rake, clearance=gamma, edge_radius=R, speed=0.0,
                           numerics=SimpleNamespace(speed_scaling=1.0), depth=0.0)
    tool = tool_array(edge, x_start=xc)
    state = fem.build_state(mesh, si, tool=tool, hourglass_ratio_max=hourglass_limit(n_across))  # the cut's guard
    dt0, _ = fem.stable_dt(state)
    k_pen = contact_stiffness(float(state.mass[state.mass > 0].min()), dt0, 1.0, TOOL_ALPHA)
    dt, limit = fem.stable_dt(state, k_pen)
    ply = ply_properties(si)
    e_n = normal_modulus(ply, math.radians(fibre_angle_deg))
    ft_ref = 0.25 * math.pi * e_n * delta * math.cos(gamma)  # the analytic bouncing term, frictionless
    rho = float(state.props[EHM, 0])
    g12 = ply.G12
    # what both outcomes report: the reference and the block
    block = {"bouncing_reference_N_per_mm": ft_ref * 1e-3, "E_n_GPa": e_n * 1e-9, "G12_GPa": g12 * 1e-9,
             "block_um": [W * 1e6, H * 1e6], "n_elements": int(mesh.n_elems)}
    c_s = math.sqrt(g12 / rho)
    omega0 = math.pi * c_s / (2 * H)
    T = 2 * math.pi / omega0
    state.params[P_DAMP] = 2 * damping * omega0
    t_load, t_hold = periods * T, (periods + hold) * T
    v_slide = mach * c_s
    t_slide = slide / v_slide
    t_end = t_hold + t_slide
    chunk = 50
    static = None
    samples = []
    sff_peak, onset = 0.0, None  # the most compressive fibre stress before the kink; the kink's onset
    y_tool0 = float(state.tool[1])
    while state.time < t_end - 1e-15:
        t = state.time
        if t < t_load:
            state.tool[3] = -0.5 * delta * (math.pi / t_load) * math.sin(math.pi * t / t_load)
            state.tool[2] = 0.0
            stop = t_load
        elif t < t_hold:
            state.tool[3] = 0.0
            state.tool[2] = 0.0
            stop = t_hold
        else:
            state.tool[3] = 0.0
            state.tool[2] = -v_slide
            stop = t_end
        forces0 = state.tool_out[TOOL_FORCE_ROWS].copy()
        s0 = state.steps
        rec = fem.advance(state, chunk, dt, k_pen=k_pen, mu=0.0, t_stop=stop)
        if onset is None:
            if float(np.abs(state.strain[:, 2]).max()) > KINK_SHEAR:
                onset = {"time_s": state.time, "interference_um": (y_tool0 - float(state.tool[1])) * 1e6,
                         "fibre_stress_GPa": sff_peak * 1e-9}
            else:
                sff_peak = min(sff_peak, float(fibre_stress(state).min()))
        if rec.status != "ok":
            return {**block, "collapsed": rec.finding, "kink_onset": onset, "steps": int(state.steps),
                    "fibre_stress_over_G12": onset["fibre_stress_GPa"] * 1e9 / g12 if onset else math.nan}
        f = _face_forces(state, forces0, state.steps - s0)
        if stop == t_hold and state.time >= t_hold - 1e-15:
            static = f  # the last chunk of the hold
        if state.time > t_hold + 0.5 * t_slide:
            samples.append((state.steps - s0, f))
    w = np.array([n for n, _ in samples], float)
    F = np.array([f for _, f in samples])
    slid = (w[:, None] * F).sum(axis=0) / w.sum()
    ft_clear = float(slid[7])
    # the analytic pressing term's elastic part at this interference: p_el = E_n tan(psi_p / 2) on the arc
    psi_p = math.acos(max(1.0 - delta / R, -1.0))
    p_el = e_n * math.tan(0.5 * psi_p)
    ft_press_el = p_el * R * math.sin(psi_p)
    e = state.energies
    return {
        **block, "clearance_thrust_N_per_mm": ft_clear * 1e-3,
        "error": abs(ft_clear - ft_ref) / ft_ref,
        "clearance_thrust_static_N_per_mm": float(static[7]) * 1e-3 if static is not None else math.nan,
        "edge_thrust_N_per_mm": float(slid[5]) * 1e-3, "pressing_elastic_reference_N_per_mm": ft_press_el * 1e-3,
        "rake_thrust_N_per_mm": float(slid[3]) * 1e-3, "total_thrust_N_per_mm": float(slid[1]) * 1e-3,
        "cutting_force_N_per_mm": float(slid[0]) * 1e-3,
        "clearance_contact_length_um": c * 1e6, "steps": int(state.steps), "dt_s": dt, "dt_limited_by": limit,
        "max_penetration_fraction_of_element": float(state.tool_out[2] / h),
        "kinetic_over_internal": e["kinetic"] / max(e["internal"], 1e-300), "energy_error": e["energy_error"],
        "fibre_stress_min_GPa": sff_peak * 1e-9,
    }


@register("tool-ploughing", "the edge sliding at a fixed interference over an elastic block: clearance-face thrust vs "
                            "the analytic bouncing term (25 %)")
def case_ploughing(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    _keys(overrides, tuple(DEFAULTS) + ("preset",))
    kw = {k: _opt(overrides, k, v) for k, v in DEFAULTS.items()}
    for k in ("interference_um", "element_size_um", "depth_over_c", "width_over_c", "slide_over_c", "periods", "mach",
              "cfl"):
        if not kw[k] > 0:
            raise ValueError(f"{k} = {kw[k]:g}: must be > 0")
    if not 0.0 <= kw["fibre_angle_deg"] <= 180.0:
        raise ValueError(f"fibre_angle_deg = {kw['fibre_angle_deg']:g}: allowed 0 to 180")
    if not kw["mach"] <= 0.2:
        raise ValueError(f"mach = {kw['mach']:g}: allowed up to 0.2 (the slide must stay quasi-static)")
    if not kw["interference_um"] <= 10.0 * kw["element_size_um"] or not kw["interference_um"] >= kw["element_size_um"]:
        raise ValueError(f"interference_um = {kw['interference_um']:g}: allowed 1 to 10 element sizes "
                         f"({kw['element_size_um']:g} um)")
    preset = str(overrides.get("preset", "t800s-m21-2d"))
    r = plough(**kw, preset=preset)
    if "collapsed" in r:  # the surface kinked: no spring-back measured (module docstring)
        onset = r["kink_onset"]
        finding = (f"the surface kinked under the edge at {onset['interference_um']:.3g} um of interference (fibre "
                   f"stress {onset['fibre_stress_GPa']:.3g} GPa = {-r['fibre_stress_over_G12']:.3g} G12)"
                   if onset else "the surface collapsed under the edge") + f"; the engine stopped: {r['collapsed']['what']}"
        return CaseResult("tool-ploughing", "clearance-face thrust [N/mm]", math.nan, r["bouncing_reference_N_per_mm"],
                          1.0, TOLERANCE, time.perf_counter() - t0,
                          {**r, **kw, "preset": preset, "finding": finding,
                           "rule": "a block whose surface collapsed under the edge measured no spring-back (error 1)"})
    return CaseResult("tool-ploughing", "clearance-face thrust [N/mm]", r["clearance_thrust_N_per_mm"],
                      r["bouncing_reference_N_per_mm"], r["error"], TOLERANCE, time.perf_counter() - t0,
                      {**r, **kw, "preset": preset})
