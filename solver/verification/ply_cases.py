"""Representative cells of the micro zone (``fibrecut verify``): does the 2D strip stack behave like a ply?

The cell is the cutting scene's own micro zone (fibre and matrix strips with cohesive interfaces, built
by :func:`solver.mesher.build_mesh` with the scene's materials), three fibre pitches high and
``length_pitches`` long, loaded quasi-statically by its top edge (velocity ramped up, then held,
mass-proportional damping at 20 % of the cell's first mode) while its bottom edge is held:

* ``ply-shear``       in-plane shear along the fibres (top edge moved along x): the shear modulus G12
  against the exact strip-stack value 1/G = sum_i f_i / G_i + n_int / (K H) (strips in series, the
  interfaces' penalty compliance; tolerance 3 %), and the peak shear stress
  against the ply's in-plane shear strength S_L = 92.3 MPa (IM7/8552, Camanho et al. 2007;
  docs/model.md), tolerance 15 %.
* ``ply-transverse``  transverse tension (top edge moved along y, the cell free to contract along x):
  the transverse modulus E2 against the exact laminate value (all strips share the strain along x,
  their x-forces cancel, each in plane strain; plus the interfaces' compliance; tolerance 3 %), and the
  peak stress against the ply's transverse tensile strength Y_T = 62.3 MPa, tolerance 15 %.

The moduli check the engine (they are exact for the strip geometry); the strengths check the material
data against the ply: a 2D strip stack need not reach a ply's strength, and when it does not the case
says so (``passed`` false, with the measured value). The stress is the reaction on the middle half of
the top edge over its length, where the cell is uniform (the free ends relieve it over about a cell height).

Overrides: ``length_pitches`` (default 16), ``element_size_um`` (2.5), ``elements_across_fibre`` (3),
``strain`` (the final strain, default 3 x the strength over the exact modulus), ``time_factor``
(loading time in transits of the slowest wave across the cell, default 30), ``preset`` (material preset),
``matrix_sigma_u_MPa`` (the matrix's tensile yield, default the preset's).
"""

from __future__ import annotations

import math
import time

import numpy as np

from solver import fem
from solver.mesh import FIBRE, MATRIX
from solver.mesher import build_mesh
from solver.scene import Scene, scene_from_dict

from . import CaseResult, register

#: ply strengths the cells are compared with (IM7/8552, Camanho, Maimi & Davila 2007, CST 67:2715; docs/model.md)
PLY_S_L = 92.3e6
PLY_Y_T = 62.3e6
ALLOWED = ("length_pitches", "element_size_um", "elements_across_fibre", "strain", "time_factor", "preset",
           "matrix_sigma_u_MPa")


def _scene(overrides: dict) -> Scene:
    pitch = 7.5 / 0.6
    h = float(overrides.get("element_size_um", 2.5))
    L = float(overrides.get("length_pitches", 16)) * pitch
    H = 3 * pitch
    materials = {"preset": overrides.get("preset", "t800s-m21-2d")}
    if "matrix_sigma_u_MPa" in overrides:  # checked as the scene's field (SceneError names it)
        materials["matrix"] = {"sigma_u_MPa": overrides["matrix_sigma_u_MPa"]}
    return scene_from_dict({
        "fidelity": "fem2d",
        "materials": materials,
        "workpiece": {"fibre_angle_deg": 0.0, "height_um": H, "length_um": L, "micro_zone_depth_um": H - h},
        "tool": {"edge_radius_um": 0.0, "rake_angle_deg": 0.0},
        "cut": {"depth_um": h, "length_um": L},
        "numerics": {"element_size_um": h, "elements_across_fibre": int(overrides.get("elements_across_fibre", 3))},
        "physics": {"element_deletion": True},
    })


def _layers(mesh, H):
    """Strip thicknesses and materials from the mesh (fibre and matrix bands, top to bottom)."""
    cy = mesh.y[mesh.quads].mean(axis=1)
    col = mesh.x[mesh.quads].mean(axis=1) < mesh.x[mesh.quads].mean(axis=1).min() + 1e-9
    ys = np.sort(np.unique(np.round(mesh.y[mesh.quads[col]].ravel(), 12)))
    out = []
    for y0, y1 in zip(ys[:-1], ys[1:]):
        sel = col & (cy > y0) & (cy < y1)
        out.append((y1 - y0, int(mesh.material[sel][0])))
    return out


def _plane_strain_C(props, m):
    from solver.fem.materials import C11, C12, C22, C66

    return props[m, C11], props[m, C12], props[m, C22], props[m, C66]


def _exact_moduli(state, mesh, H, K):
    """(G12, E2) of the strip stack: shear strips in series; transverse: common strain along x, zero net
    x-force, each strip in plane strain; plus the interfaces' penalty compliance."""
    layers = _layers(mesh, H)
    n_int = sum(1 for a, b in zip(layers[:-1], layers[1:]) if {a[1], b[1]} == {FIBRE, MATRIX})
    inv_g = sum(t / _plane_strain_C(state.props, m)[3] for t, m in layers) / H + n_int / (K * H)
    # transverse: unknowns exx (common), eyy_i; sigma_yy = C12_i exx + C22_i eyy_i = s for every strip;
    # sum_i t_i (C11_i exx + C12_i eyy_i) = 0. Solve for s = 1: eyy_i = (1 - C12_i exx) / C22_i
    a = b = 0.0
    for t, m in layers:
        c11, c12, c22, _ = _plane_strain_C(state.props, m)
        a += t * (c11 - c12 * c12 / c22)
        b += t * c12 / c22
    exx = -b / a
    eyy = sum(t * (1.0 - _plane_strain_C(state.props, m)[1] * exx) / _plane_strain_C(state.props, m)[2]
              for t, m in layers) / H + n_int / (K * H)
    return 1.0 / inv_g, 1.0 / eyy


def _run_cell(overrides: dict, mode: str):
    bad = set(overrides) - set(ALLOWED)
    if bad:
        raise ValueError(f"unknown setting(s) {sorted(bad)}; allowed: {', '.join(ALLOWED)}")
    scene = _scene(overrides)
    si = scene.si()
    mesh = build_mesh(si)
    H, L = float(si.height), float(si.length)
    tol = 1e-9 * H
    top = mesh.y > -tol
    bottom = mesh.y < -H + tol
    mesh.fixed_x[:] = False
    mesh.fixed_y[:] = False
    mesh.fixed_x[bottom] = True
    mesh.fixed_y[bottom] = True
    mesh.fixed_x[top] = True
    mesh.fixed_y[top] = True
    if mode == "transverse":  # free to contract along x: only the top's y and one bottom node's x are held
        mesh.fixed_x[top] = False
        mesh.fixed_x[bottom] = False
        mesh.fixed_x[np.flatnonzero(bottom)[0]] = True
    state = fem.build_state(mesh, si, hourglass_ratio_max=0.5)
    K = float(state.cprops[0])
    g12, e2 = _exact_moduli(state, mesh, H, K)
    modulus, strength = (g12, PLY_S_L) if mode == "shear" else (e2, PLY_Y_T)
    strain_end = float(overrides.get("strain", 3.0 * strength / modulus))
    # quasi-static pace: time_factor transits of the slowest (shear) wave across the cell's height
    rho = float(state.props[:, 0].max())
    c_slow = math.sqrt(min(g12, e2) / rho)
    t_end = float(overrides.get("time_factor", 30.0)) * H / c_slow * (strain_end / (strength / modulus))
    omega = math.pi * c_slow / (2 * H)  # the cell's first mode (a quarter wave across its height)
    state.params[3] = 2 * 0.2 * omega
    t_ramp = 0.05 * t_end
    rate = strain_end * H / (t_end - 0.5 * t_ramp)  # top-edge speed after the ramp
    # the stress is read where the cell is uniform: the reaction on the middle half of the top edge over its
    # length (the free ends relieve the shear and the transverse stress over about a cell height)
    xt = mesh.x[top]
    mid = np.flatnonzero(top)[np.abs(xt - 0.5 * L) <= 0.25 * L]
    span = float(np.ptp(mesh.x[mid])) + float(np.diff(np.sort(xt)).mean())  # the middle nodes' tributary length
    dt, _ = fem.stable_dt(state)
    n_out = 400
    strains, stresses = [], []
    while state.time < t_end:
        v = rate * min(1.0, state.time / t_ramp)
        if mode == "shear":
            state.vpx[top] = v
        else:
            state.vpy[top] = v
        rec = fem.advance(state, max(1, int(t_end / dt / n_out)))
        if rec.status != "ok":
            raise RuntimeError(f"ply-{mode} cell unstable: {rec.finding}")
        if mode == "shear":
            strains.append(float((state.x[top] - state.X0[top]).mean()) / H)
            stresses.append(float(-state.fx[mid].sum()) / span)
        else:
            strains.append(float((state.y[top] - state.Y0[top]).mean()) / H)
            stresses.append(float(-state.fy[mid].sum()) / span)
    strains, stresses = np.array(strains), np.array(stresses)
    win = max(1, len(stresses) // 50)  # the explicit run rings: read the load through a short moving average
    smooth = np.convolve(np.pad(stresses, (win // 2, win - 1 - win // 2), mode="edge"), np.ones(win) / win, mode="valid")
    peak = float(smooth.max())
    lin = (smooth > 0.1 * peak) & (smooth < 0.4 * peak) & (np.arange(smooth.size) < int(np.argmax(smooth)))
    slope = float(np.polyfit(strains[lin], smooth[lin], 1)[0]) if lin.sum() >= 3 else math.nan
    e = state.energies
    return {"modulus": slope, "modulus_exact": modulus, "peak": peak, "strength_ply": strength,
            "strain_at_peak": float(strains[int(np.argmax(smooth))]), "n_elements": mesh.n_elems,
            "n_cohesive": mesh.n_cohesive, "steps": state.steps, "energy_error": e["energy_error"],
            "failed_elements": int((state.alive == 0).sum()), "debonded_cohesive": int((state.cstate > 0).sum()),
            "curve_strain": strains[::8].tolist(), "curve_stress_Pa": smooth[::8].tolist()}


def _result(name, quantity, r, t0):
    err_mod = abs(r["modulus"] - r["modulus_exact"]) / r["modulus_exact"]
    err_str = abs(r["peak"] - r["strength_ply"]) / r["strength_ply"]
    # one error on one scale: the modulus is held to 3 %, the strength to 15 % (error / tolerance)
    err = max(err_mod / 0.03, err_str / 0.15) * 0.15
    return CaseResult(name, quantity, r["peak"], r["strength_ply"], err, 0.15, time.perf_counter() - t0,
                      {**r, "modulus_error": err_mod, "strength_error": err_str,
                       "rule": "modulus within 3 % of the exact strip stack, strength within 15 % of the ply's"})


#: what a cell case compares in each loading mode
PEAK_STRESS = {"shear": "peak in-plane shear stress [Pa]", "transverse": "peak transverse stress [Pa]"}


def register_cell_case(name: str, mode: str, description: str, run_cell, result):
    """Register the case ``name``: the cell ``run_cell(overrides, mode)`` loaded in ``mode`` (shear or
    transverse), its peak stress graded by ``result(name, quantity, r, t0)``; returns the case."""

    def case(overrides: dict) -> CaseResult:
        t0 = time.perf_counter()
        return result(name, PEAK_STRESS[mode], run_cell(overrides, mode), t0)

    return register(name, description)(case)


case_shear = register_cell_case("ply-shear", "shear", "micro-zone cell in in-plane shear: G12 vs the exact strip "
                                "stack (3 %), strength vs the ply's S_L (15 %)", _run_cell, _result)
case_transverse = register_cell_case("ply-transverse", "transverse", "micro-zone cell in transverse tension: E2 vs the "
                                     "exact strip stack (3 %), strength vs the ply's Y_T (15 %)", _run_cell, _result)
