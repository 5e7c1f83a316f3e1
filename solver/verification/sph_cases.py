"""Verification cases of solid SPH and of the FEM-to-SPH conversion (``fibrecut verify``).

* ``sph-plate``  Gray, Monaghan & Swift (2001, CMAME 190:6641) oscillating plate: a cantilever plate
  L = 0.2, H = 0.02, E = 2e6 Pa, nu = 0.3975, rho = 1000, clamped over L/4, given the first-mode
  velocity profile v_y(x) = V_f c0 M(x)/Q (Gray et al.'s normalisation; kL = 1.875, V_f = 0.05);
  its frequency against thin-plate theory omega^2 = E H^2 k^4 / (12 rho (1 - nu^2)) (plane strain).
  The case gives the outermost row of particles (smallest singular value of M below 0.6) the
  quadratic-complete gradient of :mod:`solver.sph.quadratic` (``PLATE_QUADRATIC``; off in every
  other scene). Measured (Gray's amplitude, clamp particles held fixed, eps = 0.3, one thread;
  ``NUMBA_NUM_THREADS=1 python scripts/sph_plate_table.py --n 6,8,10,12,14,16 --variants
  fixed:0.3:0.6,fixed:0.3:0,mirror:0.3:0,mirror:0.3:0.6``), error against thin-plate theory:

  ====  =====================  ==========================  ======================  ===================
  n     first-order (before)   quadratic surface row (now)  first-order + mirror    quadratic + mirror
  ====  =====================  ==========================  ======================  ===================
  6     -15.9 %                -8.23 %
  8     -11.0 %                -6.52 %                      -9.23 %                 -4.02 %
  10    -8.5 %                 -5.60 %                      -7.13 %                 unstable after T
  12    -7.1 %                 -5.03 %                      unstable after T/2      unstable after T/2
  14                           -4.68 %
  16    -6.2 %                 -4.63 %                      unstable after T/2
  ====  =====================  ==========================  ======================  ===================

  so the 5 % of the issue is met from n = 14 (about 100 s on one thread; the test runs it to T/2).
  The mirror clamp (``clamp="mirror"``, :mod:`solver.sph.boundary`) moves the clamp to its face
  (+1.8 % at n = 8, +1.4 % at n = 10) but at Gray's amplitude the compressed clamp corner disorders
  the particles from n = 10-12 on and the run blows up, so the case keeps the fixed clamp.
  eps = 0.2 instead of 0.3 gains 0.8 % (first-order, n = 10 and 12; with the quadratic row n = 10 is
  then at -4.82 %) and stays intact; eps = 0.1 clumps (n = 10: -28 %); the default stays 0.3. Where the error of the first-order formulation comes from
  (each part measured separately, with scripts/sph_plate_table.py):

  - the reference is fair: the 2D plane-strain continuum (Q9 finite elements, rigid clamp) is 0.44 %
    below thin-plate theory, Timoshenko (kappa = 5/6) 0.9 %; the project's geometrically nonlinear
    FEM at Gray's amplitude (tip deflection 0.44 L) 0.33 % (amplitude: +0.07 %);
  - the bending discretisation (an infinite periodic strip, the linearised SPH operator against the
    exact Lamb A0 mode): -10.6 % (6), -6.2 % (8), -4.1 % (10), -2.9 % (12), -1.7 % (16), about
    -4.2 / n^2. The first-order gradient correction is exact for linear fields only; at a free surface
    (one-sided support) its error for the quadratic bending field is O(h), so the outermost row, which
    carries a quarter of the bending energy, sees a bending strain 7 % too small (n = 10): what the
    quadratic surface row removes;
  - the clamp and the free end: about -1.8 % at n = 10 (a fixed-particle clamp acts about 0.75 dp
    inside the clamp; each dp by which the fixed region is moved changes omega by 1.85 %);
  - the artificial stress: -2.2 % at n = 10 and 12, not falling with resolution (in a smooth field
    it acts like an extra stress -eps c_f sigma^+ with c_f = 0.41 at h = 1.3 dp, n = 4, so tension is
    12 % softer at eps = 0.3). Without it (eps = 0) the plate clumps at Gray's amplitude (nearest
    neighbour 0.4 dp after T/4, half the energy to the viscosity), so the case keeps it.

  The linearised SPH (small amplitude, eps = 0; the dynamic run agrees with the operator's
  eigenvalue to 0.02 %) is at -6.3 % (10), -4.8 % (12), -3.3 % (16), -2.5 % (20).
* ``sph-rings``  the same paper's colliding rubber rings (inner radius 0.03, outer 0.04, E = 1e7,
  nu = 0.3975, rho = 1, each approaching at 0.059 c0): rebound without fracture or clumping,
  total-energy drift below 1 %.
* ``sph-wave``   the longitudinal wave speed of an SPH bar in uniaxial strain against
  c = sqrt(C11 / rho) (isotropic: plane-strain P wave; fibre at 0 deg: along the fibre), from the
  first-mode periods of fixed-fixed bars of lengths L and 2L, c = 2 L / (T_2L - T_L) (the bar is
  prestressed in compression so that the artificial stress, which softens tension, is inactive;
  see :func:`build_bar`).
* ``sph-conversion``  conversion bookkeeping: elements converting mid-run conserve mass exactly and
  momentum to round-off (:mod:`solver.sph.conversion`).

c0 = sqrt(K / rho), K = E / (3 (1 - 2 nu)), as in Gray et al. 2001.
"""

from __future__ import annotations

import math
import time

import numpy as np

from solver.sph import loop, materials as mt, particles as pp
from solver.sph.particles import VX, VY, X, Y

from . import CaseResult, _opt, register


def _bulk_speed(E, nu, rho):
    return math.sqrt(E / (3.0 * (1.0 - 2.0 * nu)) / rho)


# ----------------------------------------------------------------------------- oscillating plate
#: first-mode angular frequency of the same plate as a 2D plane-strain continuum with a rigid clamp
#: face (u = 0 on x = 0): biquadratic (Q9) finite elements, 200 x 20 (100 x 10 gives 24.6268), computed
#: once with scipy's eigsh; 0.44 % below thin-plate theory (shear, rotary inertia, clamp face)
PLATE_OMEGA_2D_CONTINUUM = 24.6213
#: the plate case's surface-gradient switch: the outermost row (smallest singular value of M below 0.6:
#: a flat surface has 0.5, a lattice corner 0.27, the next row about 1) takes the quadratic-complete
#: gradient of :mod:`solver.sph.quadratic`; 0.95 (two rows) clumps at Gray's amplitude
PLATE_QUADRATIC = 0.6


def plate_theory_omega(L=0.2, H=0.02, E=2e6, nu=0.3975, rho=1000.0, kL=1.875) -> float:
    """Thin-plate (plane strain) first-mode angular frequency of the cantilever."""
    k = kL / L
    return math.sqrt(E * H * H * k**4 / (12.0 * rho * (1.0 - nu * nu)))


def build_plate(n_thick=10, L=0.2, H=0.02, E=2e6, nu=0.3975, rho=1000.0, kL=1.875, Vf=0.05, h_factor=1.3,
                clamp="fixed", eps=0.3, quadratic=PLATE_QUADRATIC):
    """The plate and its clamp (Gray et al. 2001 sec. 5.1). ``clamp``: "fixed" (the particles of the
    clamp region x in [-L/4, 0] held at rest, as Gray et al.), "mirror" (6 layers of mirror ghosts
    behind x = 0, placed from the plate particles with the odd displacement and carrying their stress,
    :mod:`solver.sph.boundary`) or "mirror-linear" (the same with the stress extrapolated linearly).
    ``eps`` the artificial-stress factor, ``quadratic`` the surface-gradient switch of
    :func:`solver.sph.particles.make_params` (0: the first-order corrected gradient everywhere).
    Returns (particles, index of the tip particle)."""
    if clamp not in ("fixed", "mirror", "mirror-linear"):
        raise ValueError(f"clamp = {clamp!r}: allowed 'fixed', 'mirror', 'mirror-linear'")
    dp = H / n_thick
    mats = mt.table(mt.isotropic(E, nu, rho))
    prm = pp.make_params(dp, h_factor=h_factor, eps=eps, quadratic=quadratic)
    x, y = pp.lattice(-L / 4, L, -H / 2, H / 2, dp)
    if clamp != "fixed":  # ghosts only as deep as they act: two kernel supports (4 h), whole layers
        depth = math.ceil(2 * 2 * h_factor) * dp
        keep = x > -depth
        x, y = x[keep], y[keep]
    k = kL / L

    def M_(xx):  # first cantilever mode shape, clamped at x = 0 (Gray et al. 2001 sec. 5.1)
        return ((np.cos(kL) + np.cosh(kL)) * (np.cosh(k * xx) - np.cos(k * xx))
                + (np.sin(kL) - np.sinh(kL)) * (np.sinh(k * xx) - np.sin(k * xx)))

    Q = 2.0 * (np.cos(kL) * np.sinh(kL) - np.sin(kL) * np.cosh(kL))
    c0 = _bulk_speed(E, nu, rho)
    clamp_region = x < 0
    vy = np.where(clamp_region, 0.0, Vf * c0 * M_(np.maximum(x, 0.0)) / Q)
    P = pp.from_points(x, y, mats, prm, vy=vy, fixed=clamp_region)
    if clamp.startswith("mirror"):
        from solver.sph.boundary import mirror_pairs

        idx, centre, _ = mirror_pairs(x, y, 0.0, 1e-3 * dp, stress="linear" if clamp == "mirror-linear" else "even")
        P.set_mirror(idx, centre)
    tip = int(np.argmin((x - (L - dp / 2)) ** 2 + y**2))
    return P, tip


def run_plate(n_thick=10, periods=1.0, Vf=0.05, max_wall_s=600.0, clamp="fixed", eps=0.3, quadratic=PLATE_QUADRATIC):
    """Run the plate for about ``periods`` theory periods; returns (omega_sph, omega_theory, details).
    ``clamp``, ``eps``, ``quadratic``: see :func:`build_plate`."""
    P, tip = build_plate(n_thick=n_thick, Vf=Vf, clamp=clamp, eps=eps, quadratic=quadratic)
    om = plate_theory_omega()
    T = 2 * math.pi / om
    t_end = periods * T * 1.3
    y0 = P.F[Y, tip]
    e0 = P.energies()["total"]
    hist, rep = loop.run(P, t_end, sample=lambda Q: {"tip": Q.F[Y, tip] - y0}, n_samples=int(400 * periods),
                         chunk_steps=500, max_wall_s=max_wall_s)
    t, v = hist.arrays()
    d = v["tip"]
    # downward zero crossings of the tip deflection (starts at 0 going up): the first at T/2, then T
    cross = []
    for a in range(1, len(d)):
        if d[a - 1] > 0 >= d[a] or d[a - 1] < 0 <= d[a]:
            ta = t[a - 1] + (t[a] - t[a - 1]) * d[a - 1] / (d[a - 1] - d[a])
            if ta > 0.1 * T:
                cross.append(ta)
    if len(cross) >= 2:
        period = cross[1]  # second crossing after the start: one full period
    elif len(cross) == 1:
        period = 2 * cross[0]
    else:
        period = math.inf
    om_sph = 2 * math.pi / period
    e = P.energies()
    details = {"n_particles": P.n_act, "n_thick": n_thick, "clamp": clamp, "eps": eps, "quadratic": quadratic,
               "viscous_fraction": e["viscous"] / e0, "artstress_fraction": e["artificial_stress"] / e0,
               "steps": P.steps, "status": rep.status,
               "finding": rep.finding, "period_s": period, "period_theory_s": T, "crossings_s": cross,
               "max_tip_deflection_m": float(np.max(np.abs(d))), "min_distance_over_dp": P.min_distance_ratio(),
               "omega_2d_continuum": PLATE_OMEGA_2D_CONTINUUM,
               "error_vs_2d_continuum": om_sph / PLATE_OMEGA_2D_CONTINUUM - 1.0}
    return om_sph, om, details


@register("sph-plate", "Gray-Monaghan-Swift oscillating plate: SPH frequency vs thin-plate theory (5 %)")
def case_plate(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    # 14 particles through the thickness: the coarsest resolution that meets the 5 % (docstring table)
    n = _opt(overrides, "n_thick", 14, int)
    clamp = str(overrides.get("clamp", "fixed"))
    om_sph, om, det = run_plate(n_thick=n, max_wall_s=_opt(overrides, "max_wall_s", 1800.0), clamp=clamp,
                                eps=_opt(overrides, "eps", 0.3), quadratic=_opt(overrides, "quadratic", PLATE_QUADRATIC))
    err = abs(om_sph - om) / om if math.isfinite(om_sph) and det["status"] == "ok" else math.inf
    return CaseResult("sph-plate", "first-mode angular frequency [rad/s]", om_sph, om, err, 0.05,
                      time.perf_counter() - t0, det)


# ----------------------------------------------------------------------------- colliding rings
def build_rings(n_thick=10, ri=0.03, ro=0.04, E=1e7, nu=0.3975, rho=1.0, speed_factor=0.059, gap=None):
    """Two rings of concentric particle layers, centres at -/+(ro + gap/2), approaching each other."""
    dp = (ro - ri) / n_thick
    gap = 2 * dp if gap is None else gap
    mats = mt.table(mt.isotropic(E, nu, rho))
    prm = pp.make_params(dp)
    xs, ys, vols = [], [], []
    for kk in range(n_thick):
        r = ri + (kk + 0.5) * dp
        nth = max(6, int(round(2 * math.pi * r / dp)))
        th = (np.arange(nth) + 0.5 * (kk % 2)) * 2 * math.pi / nth
        xs.append(r * np.cos(th))
        ys.append(r * np.sin(th))
        vols.append(np.full(nth, 2 * math.pi * r * dp / nth))
    x1, y1, v1 = np.concatenate(xs), np.concatenate(ys), np.concatenate(vols)
    c = ro + gap / 2
    u = speed_factor * _bulk_speed(E, nu, rho)
    x = np.concatenate([x1 - c, x1 + c])
    y = np.concatenate([y1, y1])
    vx = np.concatenate([np.full(x1.size, u), np.full(x1.size, -u)])
    P = pp.from_points(x, y, mats, prm, vx=vx, volume=np.concatenate([v1, v1]))
    ring = np.concatenate([np.zeros(x1.size, int), np.ones(x1.size, int)])
    return P, ring, u


def _components(x, y, radius):
    """Number of connected components of the graph linking particles closer than ``radius``."""
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    pairs = cKDTree(np.c_[x, y]).query_pairs(radius, output_type="ndarray")
    from scipy.sparse import coo_matrix
    n = x.size
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return int(connected_components(g, directed=False)[0])


def run_rings(n_thick=10, t_end=None, max_wall_s=600.0):
    P, ring, u = build_rings(n_thick=n_thick)
    dp = float(P.prm[pp.P_DP])
    left = ring == 0
    t_end = t_end if t_end is not None else 1.5e-4 if False else 3.0 * 0.04 / u
    e0 = P.energies()["total"]

    def sample(Q):
        e = Q.energies()
        m = Q.F[pp.M]
        return {"total": e["total"], "kinetic": e["kinetic"], "internal": e["internal"], "viscous": e["viscous"],
                "artstress": e["artificial_stress"], "rmin": Q.min_distance_ratio(),
                "u_left": float(np.sum(m[left] * Q.F[VX][left]) / np.sum(m[left]))}

    hist, rep = loop.run(P, t_end, sample=sample, n_samples=200, chunk_steps=500, max_wall_s=max_wall_s)
    t, v = hist.arrays()
    drift = float(np.max(np.abs(v["total"] - e0)) / e0)
    comps = [_components(P.F[X][ring == r], P.F[Y][ring == r], 1.5 * dp) for r in (0, 1)]
    details = {"n_particles": P.n_act, "n_thick": n_thick, "steps": P.steps, "status": rep.status,
               "finding": rep.finding, "t_end": t_end, "approach_speed": u,
               "u_left_final_over_u0": float(v["u_left"][-1] / u),
               "min_distance_over_dp": float(np.min(v["rmin"][1:])) if len(v["rmin"]) > 1 else math.nan,
               "components_per_ring": comps, "energy_drift": drift,
               "viscous_fraction": float(v["viscous"][-1] / e0),
               "artstress_fraction": float(v["artstress"][-1] / e0)}
    return drift, details, (t, v)


@register("sph-rings", "colliding rubber rings: rebound, no fracture/clumping, total-energy drift < 1 %")
def case_rings(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    n = _opt(overrides, "n_thick", 8, int)
    drift, det, _ = run_rings(n_thick=n)
    ok = (det["status"] == "ok" and det["u_left_final_over_u0"] < 0 and det["components_per_ring"] == [1, 1]
          and det["min_distance_over_dp"] > 0.5)
    det["rebound_no_fracture_no_clumping"] = ok
    return CaseResult("sph-rings", "max relative total-energy drift", drift, 0.0, drift if ok else math.inf, 0.01,
                      time.perf_counter() - t0, det)


# ----------------------------------------------------------------------------- wave speed in a bar
def build_bar(n_long=100, n_rows=8, L=0.1, material="isotropic", prestress=1e-3, eps=None):
    """Fixed-fixed bar in uniaxial strain (all y velocities held, 3 clamped columns at each end) with
    the first-mode velocity profile v_x = v0 sin(pi x / L), v0 = 1e-4 c. The bar carries a uniform
    hydrostatic compressive prestress ``prestress`` x C11 (in equilibrium between the clamps), larger
    than the wave's stress amplitude, so the wave runs with the full production formulation (artificial
    stress on) but in compression, where the artificial stress is inactive by construction."""
    dp = L / n_long
    if material == "isotropic":
        row = mt.isotropic(2.96e9, 0.4, 1280.0)
    elif material == "fibre":
        row = mt.transversely_isotropic(294e9, 14e9, 28e9, 0.2, 0.25, 1800.0)
    else:
        raise ValueError(f"material = {material!r}: allowed 'isotropic', 'fibre'")
    mats = mt.table(row)
    prm = pp.make_params(dp) if eps is None else pp.make_params(dp, eps=eps)
    x, y = pp.lattice(-3 * dp, L + 3 * dp, 0.0, n_rows * dp, dp)
    c = math.sqrt(row[mt.M_C11] / row[mt.M_RHO0])
    v0 = 1e-4 * c
    inside = (x > 0) & (x < L)
    vx = np.where(inside, v0 * np.sin(math.pi * np.clip(x, 0, L) / L), 0.0)
    fixed = np.where(inside, 2, 3)
    P = pp.from_points(x, y, mats, prm, vx=vx, fixed=fixed, theta=0.0)
    P.F[pp.SXX] = P.F[pp.SYY] = P.F[pp.ESXX] = P.F[pp.ESYY] = -prestress * row[mt.M_C11]
    return P, c


def _bar_period(n_long, n_rows, L, material, prestress, eps):
    P, c = build_bar(n_long, n_rows, L, material, prestress, eps)
    T = 2 * L / c
    mid = np.abs(P.F[X] - L / 2) < 0.51 * P.prm[pp.P_DP] * 2
    hist, rep = loop.run(P, 1.3 * T, sample=lambda Q: {"v": float(np.mean(Q.F[VX][mid]))}, n_samples=520,
                         chunk_steps=500)
    t, v = hist.arrays()
    return first_mode_period(t, v["v"]), c, P, rep


def first_mode_period(t, d):
    """Period of a bar's first mode from the mid-bar velocity d(t), which starts at its maximum: twice the
    spacing of its first two zero crossings (at T/4 and 3T/4, either way, each placed by linear
    interpolation); inf with fewer than two."""
    cross = [t[a - 1] + (t[a] - t[a - 1]) * d[a - 1] / (d[a - 1] - d[a]) for a in range(1, len(d))
             if (d[a - 1] > 0 >= d[a]) or (d[a - 1] < 0 <= d[a])]
    return 2 * (cross[1] - cross[0]) if len(cross) >= 2 else math.inf


def run_bar(n_long=50, n_rows=8, dp=1e-3, material="isotropic", prestress=1e-3, eps=None):
    """Wave speed from the first-mode periods of two fixed-fixed bars of lengths L and 2L at the same
    spacing: c = 2 (2L - L) / (T_2L - T_L). The difference removes the clamp's effective position
    (the SPH wall sits about 1-2 dp beyond the last free particle), which would otherwise read as a
    first-order length error. Returns (c_sph, c_theory, details)."""
    L = n_long * dp
    T1, c, P1, r1 = _bar_period(n_long, n_rows, L, material, prestress, eps)
    T2, _, P2, r2 = _bar_period(2 * n_long, n_rows, 2 * L, material, prestress, eps)
    c_sph = 2 * L / (T2 - T1)
    status = "ok" if r1.status == r2.status == "ok" else "unstable"
    return c_sph, c, {"n_particles": P1.n_act + P2.n_act, "steps": P1.steps + P2.steps, "status": status,
                      "material": material, "period_L_s": T1, "period_2L_s": T2, "L_m": L,
                      "c_single_bar": 2 * L / T1, "n_long": n_long, "n_rows": n_rows,
                      "prestress_over_C11": prestress}


@register("sph-wave", "longitudinal wave speed of an SPH bar (uniaxial strain) vs sqrt(C11/rho) (3 %)")
def case_wave(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    n = _opt(overrides, "n_long", 50, int)
    mat = str(overrides.get("material", "isotropic"))
    c_sph, c, det = run_bar(n_long=n, material=mat)
    err = abs(c_sph - c) / c if det["status"] == "ok" else math.inf
    return CaseResult("sph-wave", f"longitudinal wave speed [m/s] ({mat})", c_sph, c, err, 0.03,
                      time.perf_counter() - t0, det)


# ----------------------------------------------------------------------------- conversion bookkeeping
def run_conversion_bar(nx=30, ny=6, a=1e-6, seed=11, n_steps=300):
    """A bar of nx x ny quads (fibre and matrix) whose elements convert in two waves mid-run. The
    surviving nodes drift force-free and the converted particles follow SPH, so the total mass and
    momentum (nodes + particles) must stay what they were, to round-off; the kinetic energy lost at
    conversion is booked. Returns (relative mass change, relative momentum change, details)."""
    from solver.sph import conversion as cv

    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.arange(nx + 1) * a, np.arange(ny + 1) * a, indexing="ij")
    X0, Y0 = xs.ravel().copy(), ys.ravel().copy()
    nid = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    quads = np.array([[nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]]
                      for i in range(nx) for j in range(ny)], np.int64)
    x, y = X0.copy(), Y0.copy()
    material = np.where(np.arange(len(quads)) % 3 == 0, 0, 1).astype(np.int8)
    mats = mt.table(mt.transversely_isotropic(294e9, 14e9, 28e9, 0.2, 0.25, 1800.0, D0=0.8, kappa_f=0.02),
                    mt.isotropic(2.96e9, 0.4, 1280.0, D0=0.8, kappa_f=0.025))
    elem_mass = mats[material, mt.M_RHO0] * a * a
    node_mass = np.zeros(X0.size)
    np.add.at(node_mass, quads.reshape(-1), np.repeat(0.25 * elem_mass, 4))
    C = cv.build_dormant(material, np.array([True, True]), mats, pp.make_params(a))
    P = C.particles
    ne = len(quads)
    vx = 0.5 + rng.normal(0, 0.3, X0.size)
    vy = rng.normal(0, 0.3, X0.size)
    sxx, syy, sxy = rng.normal(0, 3e7, (3, ne))
    theta0 = np.zeros(ne)
    alive = np.ones(ne, np.uint8)

    def totals():
        ia = P.active_indices()
        return (node_mass.sum() + P.F[pp.M, ia].sum(),
                (node_mass * vx).sum() + (P.F[pp.M, ia] * P.F[VX, ia]).sum(),
                (node_mass * vy).sum() + (P.F[pp.M, ia] * P.F[VY, ia]).sum())

    m0, px0, py0 = totals()
    dt = 0.2 * a / 13000.0
    status = "ok"

    def drift(n):
        nonlocal status, x, y
        for _ in range(n // 10):
            x += 10 * dt * vx
            y += 10 * dt * vy
            if P.n_act:
                r = loop.step_chunk(P, 10, dt)
                if r.status != "ok":
                    status = r.status
    for batch in (np.arange(0, ne, 2), np.arange(1, ne, 4)):
        drift(n_steps // 3)
        alive[batch] = 0
        C.convert(alive, quads, X0, Y0, x, y, vx, vy, node_mass, elem_mass, sxx, syy, sxy, theta0)
    drift(n_steps // 3)
    m1, px1, py1 = totals()
    pscale = float(elem_mass.sum() * max(np.abs(vx).max(), np.abs(P.F[VX]).max()))
    dm = abs(m1 - m0) / m0
    dp_ = math.hypot(px1 - px0, py1 - py0) / pscale
    return dm, dp_, {"elements": ne, "converted": C.n_converted, "status": status,
                     "kinetic_energy_lost_J_per_m": P.e_conversion, "momentum_change_rel": dp_, "mass_change_rel": dm}


@register("sph-conversion", "FEM-to-SPH conversion mid-run: mass exact, momentum to round-off")
def case_conversion(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    dm, dpm, det = run_conversion_bar(nx=_opt(overrides, "nx", 30, int), ny=_opt(overrides, "ny", 6, int))
    err = max(dm, dpm) if det["status"] == "ok" else math.inf
    return CaseResult("sph-conversion", "max relative change of mass and momentum", err, 0.0, err, 1e-12,
                      time.perf_counter() - t0, det)
