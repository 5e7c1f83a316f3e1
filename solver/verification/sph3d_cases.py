"""Verification cases of the 3D solid SPH (:mod:`solver.sph3d`) and of the hexahedron-to-particle
conversion (``fibrecut verify``).

* ``sph3d-wave``  the longitudinal wave speed of a 3D SPH bar in uniaxial strain (every particle's y and
  z velocities held, three clamped layers at each end) against the P-wave speed
  c = sqrt((lambda + 2G) / rho), from the first-mode periods of fixed-fixed bars of lengths L and 2L at
  the same spacing, c = 2 L / (T_2L - T_L) (the difference removes the clamps' effective position);
  the bar is prestressed in hydrostatic compression larger than the wave's stress, so the artificial
  stress (which softens tension) is inactive: the 2D ``sph-wave`` case in 3D.
* ``sph3d-collision``  two elastic spheres colliding head on (Gray, Monaghan & Swift 2001's colliding
  rubber rings, CMAME 190:6641 sec. 5.3, in 3D: E = 1e7 Pa, nu = 0.3975, rho = 1 kg/m3, each
  approaching at 0.059 c0, c0 = sqrt(K / rho)): they rebound (the left sphere's mean velocity reverses)
  without fracture (each sphere stays one connected cloud) or clumping (no pair closer than dp / 2),
  and the total energy (kinetic + stress work + viscous dissipation + artificial-stress work) drifts
  by less than 1 % of the initial kinetic energy.
* ``sph3d-conversion``  failed hexahedra of the 3D engine converted to particles in two waves while
  the particles run SPH and the surviving nodes drift: mass and momentum of nodes + particles
  conserved to 1e-12 (relative).
"""

from __future__ import annotations

import math
import time

import numpy as np

from solver.sph import materials as mt
from solver.sph3d import loop, particles as pp

from . import CaseResult, _opt, register
from .sph_cases import first_mode_period


# ----------------------------------------------------------------------------- wave speed in a bar
def build_bar3(n_long=40, n_cross=4, dp=1e-3, prestress=1e-3, E=2.96e9, nu=0.4, rho=1280.0):
    """Fixed-fixed bar (x from 0 to L = n_long dp, cross-section n_cross^2 particles) in uniaxial strain,
    first-mode velocity v_x = v0 sin(pi x / L), v0 = 1e-4 c, hydrostatic prestress -prestress C11.
    Returns (particles, c = sqrt(C11 / rho), L)."""
    L = n_long * dp
    row = mt.isotropic(E, nu, rho)
    mats = mt.table(row)
    x = pp.lattice3((-3 * dp, 0.0, 0.0), (L + 3 * dp, n_cross * dp, n_cross * dp), dp)
    c = math.sqrt(row[mt.M_C11] / row[mt.M_RHO0])
    inside = (x[0] > 0) & (x[0] < L)
    v = np.zeros_like(x)
    v[0] = np.where(inside, 1e-4 * c * np.sin(math.pi * np.clip(x[0], 0, L) / L), 0.0)
    P = pp.from_points(x, mats, pp.make_params(dp), v=v, fixed=np.where(inside, 6, 7))
    P.sig[0:3] = -prestress * row[mt.M_C11]
    return P, c, L


def _bar_period(n_long, n_cross, dp, prestress):
    P, c, L = build_bar3(n_long, n_cross, dp, prestress)
    T = 2 * L / c
    mid = np.abs(P.x[0] - L / 2) < 1.01 * dp
    hist, rep = loop.run(P, 1.3 * T, sample=lambda Q: {"v": float(np.mean(Q.v[0, mid]))}, n_samples=400,
                         chunk_steps=500)
    t, vals = hist.arrays()
    return first_mode_period(t, vals["v"]), c, P, rep


def run_bar3(n_long=40, n_cross=4, dp=1e-3, prestress=1e-3):
    """c = 2 (2L - L) / (T_2L - T_L) of two bars; returns (c_sph, c_theory, details)."""
    L = n_long * dp
    T1, c, P1, r1 = _bar_period(n_long, n_cross, dp, prestress)
    T2, _, P2, r2 = _bar_period(2 * n_long, n_cross, dp, prestress)
    c_sph = 2 * L / (T2 - T1)
    status = "ok" if r1.status == r2.status == "ok" else f"{r1.status}/{r2.status}"
    return c_sph, c, {"n_particles": P1.n + P2.n, "steps": P1.steps + P2.steps, "status": status,
                      "period_L_s": T1, "period_2L_s": T2, "L_m": L, "c_single_bar": 2 * L / T1,
                      "n_long": n_long, "n_cross": n_cross, "prestress_over_C11": prestress}


@register("sph3d-wave", "3D SPH bar (uniaxial strain): P-wave speed vs sqrt((lambda+2G)/rho) (3 %)")
def case_wave(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    c_sph, c, det = run_bar3(n_long=_opt(overrides, "n_long", 40, int), n_cross=_opt(overrides, "n_cross", 4, int))
    err = abs(c_sph - c) / c if det["status"] == "ok" else math.inf
    return CaseResult("sph3d-wave", "P-wave speed [m/s]", c_sph, c, err, 0.03, time.perf_counter() - t0, det)


# ----------------------------------------------------------------------------- colliding spheres
def build_spheres(n_radius=6, R=0.01, E=1e7, nu=0.3975, rho=1.0, speed_factor=0.059, gap=None):
    """Two solid spheres of radius R (n_radius particles of a cubic lattice across a radius), centres on
    the x axis a surface gap ``gap`` (default 2.5 dp: beyond the kernel's reach once the lattice's
    surface roughness is counted) apart, approaching at u = speed_factor c0 each,
    c0 = sqrt(K / rho) (Gray et al. 2001). Returns (particles, sphere id per particle, u)."""
    dp = R / n_radius
    gap = 2.5 * dp if gap is None else gap
    mats = mt.table(mt.isotropic(E, nu, rho))
    g = pp.lattice3((-R, -R, -R), (R, R, R), dp)
    g = g[:, np.sum(g * g, axis=0) <= R * R]
    c = R + gap / 2
    x = np.hstack([g - np.array([[c], [0], [0]]), g + np.array([[c], [0], [0]])])
    u = speed_factor * math.sqrt(E / (3.0 * (1.0 - 2.0 * nu)) / rho)
    k = g.shape[1]
    v = np.zeros_like(x)
    v[0, :k] = u
    v[0, k:] = -u
    P = pp.from_points(x, mats, pp.make_params(dp), v=v)
    return P, np.repeat([0, 1], k), u


def _components(x, radius):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(x.T).query_pairs(radius, output_type="ndarray")
    n = x.shape[1]
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return int(connected_components(g, directed=False)[0])


def run_spheres(n_radius=6, t_travel=3.0, max_wall_s=600.0):
    """Collide the spheres for the time each takes to travel ``t_travel`` radii at its approach speed;
    returns (energy drift / initial energy, details, (t, samples))."""
    P, sphere, u = build_spheres(n_radius=n_radius)
    R = 0.01
    dp = float(P.prm[pp.P_DP])
    left = sphere == 0
    e0 = P.energies()["total"]

    def sample(Q):
        e = Q.energies()
        return {"total": e["total"], "kinetic": e["kinetic"], "internal": e["internal"], "viscous": e["viscous"],
                "artstress": e["artificial_stress"], "rmin": Q.min_distance_ratio(),
                "u_left": float(np.sum(Q.m[left] * Q.v[0, left]) / np.sum(Q.m[left]))}

    hist, rep = loop.run(P, t_travel * R / u, sample=sample, n_samples=200, chunk_steps=200, max_wall_s=max_wall_s)
    t, v = hist.arrays()
    drift = float(np.max(np.abs(v["total"] - e0)) / e0)
    comps = [_components(P.x[:, sphere == s], 1.5 * dp) for s in (0, 1)]
    mom = P.momentum()
    det = {"n_particles": P.n, "n_radius": n_radius, "steps": P.steps, "status": rep.status, "approach_speed": u,
           "u_left_final_over_u0": float(v["u_left"][-1] / u),
           "kinetic_recovered": float(v["kinetic"][-1] / v["kinetic"][0]),
           "min_distance_over_dp": float(np.min(v["rmin"][1:])) if len(v["rmin"]) > 1 else math.nan,
           "components_per_sphere": comps, "energy_drift": drift,
           "viscous_fraction": float(v["viscous"][-1] / e0), "artstress_fraction": float(v["artstress"][-1] / e0),
           "momentum_x_final_over_sphere_momentum": float(mom[0] / (np.sum(P.m[left]) * u))}
    return drift, det, (t, v)


@register("sph3d-collision", "colliding elastic spheres (3D): rebound, no fracture/clumping, energy drift < 1 %")
def case_collision(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    drift, det, _ = run_spheres(n_radius=_opt(overrides, "n_radius", 6, int))
    ok = (det["status"] == "ok" and det["u_left_final_over_u0"] < 0 and det["components_per_sphere"] == [1, 1]
          and det["min_distance_over_dp"] > 0.5)
    det["rebound_no_fracture_no_clumping"] = ok
    return CaseResult("sph3d-collision", "max relative total-energy drift", drift, 0.0, drift if ok else math.inf, 0.01,
                      time.perf_counter() - t0, det)


# ----------------------------------------------------------------------------- conversion bookkeeping
def run_conversion3(n=(8, 4, 3), a=1e-5, seed=5, n_steps=120):
    """A box of hexahedra (3D engine, isotropic epoxy) set moving at random, advanced 20 engine steps
    (so the elements carry stress), then converted in two waves (every second element, then every fifth
    of the rest) while the particles run SPH and the surviving nodes drift force-free; returns (relative
    mass change, relative momentum change, details)."""
    from solver.fem3d import gridmesh3d, loop as floop, material3d
    from solver.sph3d import conversion as cv

    mesh = gridmesh3d.box_mesh(n[0], n[1], n[2], n[0] * a, n[1] * a, n[2] * a, perturb=0.1, seed=seed)
    s = floop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(2.96e9, 0.4)], [1280.0])
    rng = np.random.default_rng(seed)
    s.v[:] = rng.normal(0.3, 1.0, s.v.shape)
    floop.advance(s, 20)
    conv = cv.start(s, mt.table(mt.isotropic(2.96e9, 0.4, 1280.0)), pp.make_params(a))
    P = conv.particles

    def totals():
        return s.mass.sum() + P.m.sum(), (s.mass * s.v).sum(axis=1) + (P.m * P.v).sum(axis=1)

    m0, p0 = totals()
    pscale = float(m0 * np.abs(s.v).max())
    dt = 0.2 * a / 2500.0
    status = "ok"

    def drift(k):
        nonlocal status
        s.x += k * dt * s.v
        if P.n:
            r = loop.step_chunk(P, k, dt)
            if r.status != "ok":
                status = r.status

    ne = s.hexes.shape[0]
    first = np.arange(0, ne, 2)
    second = np.setdiff1d(np.arange(ne), first)[::5]
    for batch in (first, second):
        drift(n_steps // 3)
        conv.convert(s, batch)
    drift(n_steps // 3)
    m1, p1 = totals()
    dm = abs(m1 - m0) / m0
    dpm = float(np.linalg.norm(p1 - p0)) / pscale
    return dm, dpm, {"elements": ne, "converted": int(conv.converted.sum()), "particles": P.n, "status": status,
                     "kinetic_energy_lost_J": conv.e_conversion, "crushed": conv.n_crushed,
                     "mass_change_rel": dm, "momentum_change_rel": dpm}


@register("sph3d-conversion", "hexahedra to 3D particles mid-run: mass and momentum to round-off (1e-12)")
def case_conversion(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    dm, dpm, det = run_conversion3()
    err = max(dm, dpm) if det["status"] == "ok" else math.inf
    return CaseResult("sph3d-conversion", "max relative change of mass and momentum", err, 0.0, err, 1e-12,
                      time.perf_counter() - t0, det)
