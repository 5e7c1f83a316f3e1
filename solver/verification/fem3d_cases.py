"""Verification cases of the 3D hexahedral engine (``fibrecut verify``), each against an analytic reference.

* ``fem3d-wave-iso``    a uniaxial-strain P wave along a laterally confined bar (every node held in y
  and z): c = sqrt((lambda + 2 mu) / rho), from the arrival of half the applied velocity step at
  x = L/4 and 3L/4 (tolerance 2 %).
* ``fem3d-wave-fibre``  a plane wave along x through the transversely isotropic fibre (the scene's
  fibre data) pointing at 30 deg in the x-y plane and 20 deg out of it: the four nodes of each cross
  section are tied (plane-wave kinematics, all three components free), the left end is driven along
  the quasi-P polarization, and the speed is compared with the fastest eigenvalue of the Christoffel
  tensor Gamma_ik = C_ijkl n_j n_l, n = x (rho c^2 = lambda_max; 2 %).
* ``fem3d-patch``       a 2 x 2 x 2 patch of distorted hexahedra (every interior and face node moved
  randomly, the fibre at an oblique angle) under the affine motion x = R (I + G) X + c with a 35 deg
  rotation about an oblique axis: every element's 2nd Piola-Kirchhoff stress equals the law's at
  E = ((I + G)^T (I + G) - I) / 2, and the interior node's force resultant vanishes, to 1e-10.
* ``fem3d-cantilever``  first bending period of a clamped beam, L = 0.2 m, H = W = 0.01 m (aspect
  ratio L/H = 20), 20 elements along, 1 across, 2 and 3 through the thickness, started with the first
  mode's velocity profile, against Euler-Bernoulli: omega = (1.8751)^2 sqrt(E I / (rho A L^4)),
  I / A = H^2 / 12 (at L/H = 20 shear and rotary inertia lower it by about 0.2 %, Timoshenko);
  the error is the larger of the two meshes' (tolerance 3 %).
* ``fem3d-energy``      the 2-element-thick beam vibrating freely for 10 periods: the drift of
  kinetic + strain + hourglass energy, max |E(t) - E(0)| / E(0), below 1e-3.
* ``fem3d-dcb``         cohesive double cantilever beam (mode I): the 2D ``fem-dcb`` specimen (Alfano &
  Crisfield 2001) as a strip of 120 x 1 x (2 + 2) hexahedra and 60 cohesive elements (the bonded
  half) held across its width (plane strain): peak load against corrected beam theory (5 %),
  softening branch within 10 %.
* ``fem3d-enf``         cohesive end-notched flexure (mode II): the 2D ``fem-enf`` specimen, 200 x 1 x
  (2 + 2) hexahedra: critical load against beam theory (5 %).
* ``fem3d-bridge``      the 2D-3D bridge: the plane-strain strip of hexahedra against the 2D engine on the
  same mesh: an elastic cantilever's nodal displacements (1 %; they agree to round-off) and the DCB's
  peak load (2 %).

Overrides (``--set``): ``nx`` (elements along), per case ``periods``, ``nz`` (elements through each arm
or the strip), the bridge's ``dcb`` (0: the elastic part only); an unknown name is rejected.
"""

from __future__ import annotations

import math
import time

import numpy as np

from solver.fem3d import gridmesh3d, loop, material3d

from . import CaseResult, register
from .fem_cases import _bar_front_speed, _keys, _opt, _period

def _bar_wave(C, rho, nx, direction_of_drive, tie, length=1.0, v0=0.01, cfl=0.9):
    """Speed of a velocity step along a bar of nx cubes (one across): the drive's projection
    crossing half its amplitude at x = L/4 and 3L/4."""
    h = length / nx
    mesh = gridmesh3d.box_mesh(nx, 1, 1, length, h, h)
    s = loop.build_state(mesh.X, mesh.hexes, [C], [rho], cfl=cfl)
    i_all = np.arange(nx + 1)
    groups = np.stack([mesh.node(i_all, 0, 0), mesh.node(i_all, 1, 0), mesh.node(i_all, 0, 1), mesh.node(i_all, 1, 1)],
                      axis=1)
    p = np.asarray(direction_of_drive, float)
    p = p / np.linalg.norm(p)
    if tie:
        loop.tie_nodes(s, groups)
        s.fix[:, groups[0, 0]] = 1
        s.vp[:, groups[0, 0]] = v0 * p
    else:
        s.fix[1:, :] = 1  # lateral confinement
        s.fix[0, groups[0]] = 1
        s.vp[0, groups[0]] = v0 * p[0]
    c_pred = math.sqrt(max(np.linalg.eigvalsh(material3d.christoffel(C, [1.0, 0.0, 0.0]))) / rho)
    n1 = groups[int(round(nx / 4))]
    n2 = groups[int(round(3 * nx / 4))]

    def probe(st):
        return float((p @ st.v[:, n1]).mean()), float((p @ st.v[:, n2]).mean())

    return _bar_front_speed(s, loop.advance, probe, length, c_pred, v0), s


@register("fem3d-wave-iso", "FEM 3D: uniaxial-strain P-wave speed in a confined bar of hexahedra vs sqrt((lambda+2mu)/rho)")
def case_wave_iso(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    _keys(overrides, ("nx",))
    nx = _opt(overrides, "nx", 200, int)
    E, nu, rho = 200e9, 0.3, 7800.0
    C = material3d.isotropic_stiffness(E, nu)
    c, s = _bar_wave(C, rho, nx, [1.0, 0.0, 0.0], tie=False)
    ref = math.sqrt(C[0, 0] / rho)
    return CaseResult("fem3d-wave-iso", "P-wave speed [m/s]", c, ref, abs(c - ref) / ref, 0.02,
                      time.perf_counter() - t0, {"nx": nx, "steps": s.steps})


def fibre_data():
    """The scene's fibre (E1, E2, G12, nu12, nu23 [Pa, -], rho [kg/m^3])."""
    from solver.scene import Scene

    f = Scene().si().fibre
    return f.E1, f.E2, f.G12, f.nu12, f.nu23, f.rho


@register("fem3d-wave-fibre", "FEM 3D: quasi-P plane-wave speed through an oblique fibre vs the Christoffel eigenvalue")
def case_wave_fibre(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    _keys(overrides, ("nx",))
    nx = _opt(overrides, "nx", 200, int)
    E1, E2, G12, nu12, nu23, rho = fibre_data()
    d = material3d.fibre_direction(math.radians(30.0), math.radians(20.0))
    C = material3d.fibre_stiffness(E1, E2, G12, nu12, nu23, d)
    speeds, pol = material3d.wave_speeds(C, rho, [1.0, 0.0, 0.0])
    ref = float(speeds[0])
    p = pol[:, 0] * np.sign(pol[0, 0])
    c, s = _bar_wave(C, rho, nx, p, tie=True, length=1e-3)
    return CaseResult("fem3d-wave-fibre", "quasi-P speed along x [m/s]", c, ref, abs(c - ref) / ref, 0.02,
                      time.perf_counter() - t0,
                      {"nx": nx, "fibre_direction": d.tolist(), "polarization": p.tolist(),
                       "christoffel_speeds_m_s": speeds.tolist(), "steps": s.steps})


# ----------------------------------------------------------------------------- patch test
def _rotation(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


@register("fem3d-patch", "FEM 3D: patch test on distorted hexahedra, an affine motion with a large rotation gives constant stress")
def case_patch(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    _keys(overrides, ())
    mesh = gridmesh3d.box_mesh(2, 2, 2, 2e-3, 2e-3, 2e-3, perturb=0.3, seed=3)
    E1, E2, G12, nu12, nu23, rho = fibre_data()
    C = material3d.fibre_stiffness(E1, E2, G12, nu12, nu23, material3d.fibre_direction(math.radians(30), math.radians(25)))
    s = loop.build_state(mesh.X, mesh.hexes, [C], [rho])
    G = np.array([[1.0e-3, 0.4e-3, -0.3e-3], [-0.2e-3, -0.6e-3, 0.5e-3], [0.1e-3, 0.3e-3, 0.8e-3]])
    F = _rotation([1.0, 2.0, 3.0], math.radians(35.0)) @ (np.eye(3) + G)
    s.x[:] = F @ mesh.X + np.array([[2e-4], [-1e-4], [3e-4]])
    f, S = loop.evaluate(s)
    E = 0.5 * (F.T @ F - np.eye(3))
    Ev = np.array([E[i, j] for i, j in material3d.VOIGT])
    ref = material3d.stress_from_strain(s.cmat, 0, Ev)
    err = float(np.abs(S - ref).max() / np.abs(ref).max())
    centre = int(mesh.node(1, 1, 1))
    f_int = float(np.linalg.norm(f[:, centre]) / np.abs(f).max())
    return CaseResult("fem3d-patch", "max |S_e - S_law| / |S_law|", float(np.abs(S - ref).max()), float(np.abs(ref).max()),
                      max(err, f_int), 1e-10, time.perf_counter() - t0,
                      {"stress_error": err, "interior_force_ratio": f_int, "S_law_Pa": ref.tolist()})


# ----------------------------------------------------------------------------- cantilever
def cantilever(nx, nz, periods=2.2, L=0.2, H=0.01, W=0.01, E=2e6, nu=0.3, rho=1000.0, v_tip=1e-3, samples=200):
    """Clamped beam (x along, z the bending direction); returns (period measured, EB period, energies, state)."""
    mesh = gridmesh3d.box_mesh(nx, 1, nz, L, W, H, origin=(0.0, -W / 2, -H / 2))
    # bending with 2-3 elements through the thickness: the hourglass modes hold about 1/n^2 of its energy
    s = loop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(E, nu)], [rho], hourglass_ratio_max=0.5)
    clamp = mesh.X[0] < 1e-12
    s.fix[:, clamp] = 1
    kL = 1.875104068711961
    k = kL / L
    a = (math.cos(kL) + math.cosh(kL)) / (math.sin(kL) + math.sinh(kL))

    def phi(x):
        return np.cosh(k * x) - np.cos(k * x) - a * (np.sinh(k * x) - np.sin(k * x))

    s.v[2] = v_tip * phi(s.X0[0]) / phi(L)
    s.v[:, clamp] = 0.0
    omega = kL ** 2 * math.sqrt(E * H * H / (12 * rho * L ** 4))
    T = 2 * math.pi / omega
    tips = np.nonzero(s.X0[0] > L - 1e-12)[0]
    dt = loop.stable_dt(s)
    every = max(1, int(T / dt / samples))
    ts, us, es = [], [], []
    while s.time < periods * T:
        rec = loop.advance(s, every)
        if rec.status != "ok":
            raise RuntimeError(f"cantilever: {rec}")
        e = loop.energies(s)
        ts.append(s.time)
        us.append(float((s.x[2, tips] - s.X0[2, tips]).mean()))
        es.append(e["kinetic"] + e["internal"] + e["hourglass"])
    return _period(ts, us), T, np.array(es), s


def _beam_settings(overrides: dict, periods: float):
    """The vibrating beam's settings: elements along (``nx``, default 20) and the ``periods`` run (default
    ``periods``)."""
    _keys(overrides, ("nx", "periods"))
    return _opt(overrides, "nx", 20, int), _opt(overrides, "periods", periods)


@register("fem3d-cantilever", "FEM 3D: first bending period of a clamped beam (L/H = 20), 2 and 3 hexahedra through the thickness, vs Euler-Bernoulli")
def case_cantilever(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    nx, periods = _beam_settings(overrides, 2.2)
    out = {}
    for nz in (2, 3):
        p, T, es, s = cantilever(nx, nz, periods)
        out[nz] = (p, abs(p - T) / T, float(s.ehg.sum() / max(s.eint.sum() + s.ehg.sum(), 1e-300)))
    worst = max(out, key=lambda k: out[k][1])
    return CaseResult("fem3d-cantilever", "first bending period [s] (worst mesh)", out[worst][0], T, out[worst][1], 0.03,
                      time.perf_counter() - t0,
                      {"aspect_ratio_L_over_H": 20.0, "elements_along": nx,
                       "error_2_through_thickness": out[2][1], "error_3_through_thickness": out[3][1],
                       "period_2_s": out[2][0], "period_3_s": out[3][0],
                       "hourglass_share_2": out[2][2], "hourglass_share_3": out[3][2]})


@register("fem3d-energy", "FEM 3D: free elastic vibration of a hexahedral beam, drift of kinetic + strain energy over 10 periods")
def case_energy(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    nx, periods = _beam_settings(overrides, 10.0)
    _, T, es, s = cantilever(nx, 2, periods, samples=40)
    drift = float(np.abs(es - es[0]).max() / es[0])
    return CaseResult("fem3d-energy", "max |E(t) - E(0)| / E(0)", drift, 0.0, drift, 1e-3, time.perf_counter() - t0,
                      {"periods": periods, "steps": s.steps, "energy_error": loop.energies(s)["energy_error"]})


# ----------------------------------------------------------------------------- cohesive: DCB
def _ac2001_stiffness():
    """Alfano & Crisfield 2001's laminate (fem_cases.AC2001), the fibre along x: (C, rho, E', chi)."""
    from .fem_cases import AC2001

    d = AC2001
    C = material3d.fibre_stiffness(d["E1"], d["E2"], d["G12"], d["nu12"], d["nu23"], [1.0, 0.0, 0.0])
    E_eff = d["E1"] / (1 - d["nu12"] ** 2 * d["E2"] / d["E1"])  # plane-strain modulus along the beam
    gam = 1.18 * math.sqrt(d["E1"] * d["E2"]) / d["G12"]
    chi = math.sqrt(d["E1"] / (11 * d["G12"])) * (3 - 2 * (gam / (1 + gam)) ** 2)
    return C, d["rho"], E_eff, chi


def _moving_average(loads):
    """The load cell's moving average over 1/40 of the record (the explicit run rings)."""
    win = max(1, len(loads) // 40)
    padded = np.concatenate([np.full(win // 2, loads[0]), loads, np.full(win - 1 - win // 2, loads[-1])])
    return np.convolve(padded, np.ones(win) / win, mode="valid")


def _displacement_control(s, delta_max, t_end, drive, read, what):
    """Load a specimen quasi-statically to the displacement ``delta_max`` at ``t_end``: ``drive(s, v)`` sets the
    loaded nodes' speed v (ramped up over the first tenth of t_end to delta_max / t_end) before each of about 1200
    chunks, ``read(s)`` reads the specimen after each; returns the reads."""
    V = delta_max / t_end
    t_ramp = 0.1 * t_end
    chunk = max(1, int(t_end / loop.stable_dt(s) / 300 / 4))
    reads = []
    while s.time < t_end:
        drive(s, V * min(1.0, s.time / t_ramp))
        rec = loop.advance(s, chunk)
        if rec.status != "ok":
            raise RuntimeError(f"{what}: {rec}")
        reads.append(read(s))
    return reads


def dcb3d(nx=120, nz=2, ny=1, length=0.06, delta_max=3.5e-3, periods=10.0, penalty=1e13, zeta=0.2, cfl=0.8,
          width=1e-3):
    """The 2D ``fem-dcb`` specimen (fem_cases.case_dcb) as a strip of hexahedra, ``ny`` across the width
    ``width``, every node held across it (plane strain, the symmetry of an infinitely wide specimen): the
    arms (nz hexahedra through each) opened at x = 0 by displacement control. Returns (openings, loads
    per unit width averaged, the CBT curve, the CBT peak, state, mesh, the interface strength)."""
    from .fem_cases import AC2001, cbt_curve

    d = AC2001
    a0, h = d["a0"], d["h"]
    C, rho, E_eff, chi = _ac2001_stiffness()
    l_e = length / nx
    sigma = min(d["sigma"], math.sqrt(9 * math.pi * d["E2"] * d["GIc"] / (32 * 3 * l_e)))  # as the 2D case
    m = gridmesh3d.split_box_mesh(nx, ny, nz, nz, length, width, h, h, bonded=(a0, length))
    s = loop.build_state(m.X, m.hexes, [C], [rho], cfl=cfl, hourglass_ratio_max=0.5)
    loop.add_cohesive(s, m.cohesive, [penalty, sigma, sigma, d["GIc"], d["GIc"], 1.45])
    s.fix[1, :] = 1  # plane strain
    x = m.X
    left = x[0] < 1e-12
    upper = np.arange(m.n_nodes) >= m.n_lower
    top, bot = left & upper, left & ~upper
    s.fix[2, left] = 1
    s.fix[0, (x[0] > length - 1e-12) & (np.abs(x[2]) < 1e-12)] = 1
    c_bar = math.sqrt(E_eff / rho) * h / math.sqrt(12.0)
    ae_end = math.sqrt(delta_max * E_eff * h ** 3 / (8 * math.sqrt(d["GIc"] * E_eff * h ** 3 / 12)))
    omega_end = 1.875 ** 2 * c_bar / ae_end ** 2
    omega0 = 1.875 ** 2 * c_bar / (a0 + chi * h) ** 2
    t_end = periods * 2 * math.pi / omega_end
    s.damping = 2 * zeta * omega0

    def drive(st, vel):
        st.vp[2, top] = 0.5 * vel
        st.vp[2, bot] = -0.5 * vel

    def read(st):
        u = st.x[2] - st.X0[2]
        return float(u[top].mean() - u[bot].mean()), float(-st.f[2, top].sum()) / width

    deltas, loads = (np.array(r) for r in zip(*_displacement_control(s, delta_max, t_end, drive, read, "DCB 3D")))
    loads = _moving_average(loads)
    ref, p_ref = cbt_curve(E_eff, h, d["GIc"], a0, chi * h, deltas)
    return deltas, loads, ref, p_ref, s, m, sigma


@register("fem3d-dcb", "FEM 3D: cohesive double cantilever beam (Alfano & Crisfield 2001) as a plane-strain strip of hexahedra vs corrected beam theory")
def case_dcb(overrides: dict) -> CaseResult:
    """Mode I: the 2D ``fem-dcb`` specimen (60 mm, a0 = 30 mm, arms 1.5 mm, Alfano & Crisfield's laminate,
    the interface strength lowered so the cohesive zone spans 3 elements, penalty 1e4 N/mm^3, opened to
    3.5 mm over 10 periods with 20 % mass-proportional damping) meshed with 120 x 1 x (2 + 2) hexahedra
    (0.5 mm along, 0.75 mm through, one across a 1 mm width held in y: plane strain) and 60 cohesive
    elements over the bonded ligament 30-60 mm. Peak load per unit width against corrected beam theory
    (tolerance 5 %); the softening branch's mean deviation must stay below 10 %."""
    t0 = time.perf_counter()
    _keys(overrides, ("nx", "nz", "periods", "delta_max_mm"))
    nx = _opt(overrides, "nx", 120, int)
    nz = _opt(overrides, "nz", 2, int)
    deltas, loads, ref, p_ref, s, m, sigma = dcb3d(nx, nz, periods=_opt(overrides, "periods", 10.0),
                                                   delta_max=_opt(overrides, "delta_max_mm", 3.5) * 1e-3)
    p_peak = float(loads.max())
    err_peak = abs(p_peak - p_ref) / p_ref
    i_peak = int(np.argmax(loads))
    soft = deltas > deltas[i_peak] * 1.3
    err_soft = float(np.mean(np.abs(loads[soft] - ref[soft]) / ref[soft])) if soft.any() else math.nan
    err = err_peak if (soft.any() and err_soft < 0.10) else max(err_peak, 1.0)
    e = loop.energies(s)
    return CaseResult("fem3d-dcb", "peak load [N/m]", p_peak, p_ref, err, 0.05, time.perf_counter() - t0,
                      {"mesh": [nx, 1, nz, nz], "n_hexahedra": m.n_elems, "n_cohesive": m.n_cohesive,
                       "softening_mean_error": err_soft, "interface_strength_Pa": sigma, "steps": s.steps,
                       "energy_error": e["energy_error"], "cohesive_unaccounted_over_external":
                       e["cohesive_unaccounted"] / max(e["external"], 1e-300),
                       "viscous_over_external": e["viscous"] / max(e["external"], 1e-300),
                       "debonded": int((s.cstate > 0).sum()),
                       "curve_mm_N_per_mm": [[float(a * 1e3), float(b * 1e-3)] for a, b in zip(deltas[::10], loads[::10])]})


# ----------------------------------------------------------------------------- the 2D-3D bridge
def bridge_cantilever(nx=20, nz=4, quarter_periods=1.0, L=0.2, H=0.01, W=0.01, E=2e6, nu=0.3, rho=1000.0, v_tip=1e-3):
    """The clamped strip of ``fem-cantilever`` (isotropic) in both engines on the same mesh, nx x nz quads
    and nx x 1 x nz hexahedra held across the width (plane strain), started with the first mode's
    velocity profile and run with the same step to the same time (``quarter_periods`` quarter periods of
    the thin-plate mode). Returns (max over nodes |u_3D - u_2D| / max |u_2D|, the same for the arms' tip,
    time, steps)."""
    from solver import fem
    from solver.fem.gridmesh import rect_mesh

    from .fem_cases import _si

    si = _si(0.9, E=E, nu=nu, rho=rho, sigma_u=1e12)
    m2 = rect_mesh(nx, nz, L, H, material=1, y0=-H / 2)
    clamp2 = m2.x < 1e-12
    m2.fixed_x[clamp2] = True
    m2.fixed_y[clamp2] = True
    s2 = fem.build_state(m2, si, hourglass_ratio_max=0.5)
    m3 = gridmesh3d.box_mesh(nx, 1, nz, L, W, H, origin=(0.0, 0.0, -H / 2))
    s3 = loop.build_state(m3.X, m3.hexes, [material3d.isotropic_stiffness(E, nu)], [rho], hourglass_ratio_max=0.5)
    s3.fix[1, :] = 1  # plane strain: no motion normal to the two faces
    s3.fix[:, m3.X[0] < 1e-12] = 1
    kL = 1.875
    k = kL / L
    a = (math.cos(kL) + math.cosh(kL)) / (math.sin(kL) + math.sinh(kL))

    def phi(x):
        return v_tip * (np.cosh(k * x) - np.cos(k * x) - a * (np.sinh(k * x) - np.sin(k * x))) / (
            np.cosh(k * L) - np.cos(k * L) - a * (np.sinh(k * L) - np.sin(k * L)))

    s2.vy[:] = phi(s2.X0)
    s2.vy[clamp2] = 0.0
    s3.v[2] = phi(s3.X0[0])
    s3.v[:, m3.X[0] < 1e-12] = 0.0
    T = 2 * math.pi / math.sqrt(E * H * H * k ** 4 / (12 * rho * (1 - nu * nu)))
    dt = 0.5 * min(fem.stable_dt(s2)[0], loop.stable_dt(s3))
    n = int(round(quarter_periods * T / 4 / dt))
    done = 0
    while done < n:
        step = min(2000, n - done)
        r2 = fem.advance(s2, step, dt=dt)
        r3 = loop.advance(s3, step, dt=dt)
        if r2.status != "ok" or r3.status != "ok" or r2.steps != step or r3.steps != step:
            raise RuntimeError(f"bridge: 2D {r2}, 3D {r3}")
        done += step
    # the 3D nodes (i, j, k), j = 0 and 1, against the 2D node at (x_i, z_k)
    key2 = {(round(x / L * 8 * nx), round(y / H * 8 * nz)): i for i, (x, y) in enumerate(zip(s2.X0, s2.Y0))}
    u2 = np.zeros((2, m3.n_nodes))
    for i in range(m3.n_nodes):
        j = key2[(round(m3.X[0, i] / L * 8 * nx), round(m3.X[2, i] / H * 8 * nz))]
        u2[0, i] = s2.x[j] - s2.X0[j]
        u2[1, i] = s2.y[j] - s2.Y0[j]
    u3 = (s3.x - s3.X0)[[0, 2]]
    err = float(np.abs(u3 - u2).max() / np.abs(u2).max())
    tips = m3.X[0] > L - 1e-12
    err_tip = float(abs(u3[1, tips].mean() - u2[1, tips].mean()) / abs(u2[1, tips].mean()))
    return err, err_tip, s3.time, n, float(np.abs(u3[1] - u2[1]).max())


@register("fem3d-bridge", "FEM 3D vs 2D: a one-element-thick plane-strain strip of hexahedra reproduces the 2D engine (elastic cantilever; cohesive DCB)")
def case_bridge(overrides: dict) -> CaseResult:
    """The 2D-3D bridge. (1) Elastic: the clamped isotropic strip of ``fem-cantilever`` (L = 0.2 m, H = 0.01 m,
    E = 2 MPa, nu = 0.3, 20 x 4 elements), one hexahedron across the width with both faces held (no motion
    normal to them), run from the first mode's velocity profile with the same step as the 2D engine on the
    same mesh to a quarter period (the largest deflection): the nodal displacements agree within 1 % of
    the largest (the error). Isotropic, since the 2D engine's transversely isotropic law is written in its
    own plane-strain axes. (2) Cohesive (``dcb`` = 1, the default; 0 skips it): the DCB of ``fem3d-dcb`` and
    of ``fem-dcb`` on the same coarse mesh (60 x 2 + 2 elements, 5 periods): peak loads within 2 %."""
    t0 = time.perf_counter()
    _keys(overrides, ("nx", "nz", "dcb"))
    nx = _opt(overrides, "nx", 20, int)
    nz = _opt(overrides, "nz", 4, int)
    err, err_tip, t, steps, umax = bridge_cantilever(nx, nz)
    extra = {"mesh": [nx, 1, nz], "error_tip_deflection": err_tip, "time_s": t, "steps": steps, "tolerance_dcb": 0.02}
    value = err
    if _opt(overrides, "dcb", 1, int):
        from solver.verification import fem_cases

        r2 = fem_cases.case_dcb({"nx": 60, "periods": 5.0})
        _, loads, _, _, _, _, _ = dcb3d(60, 2, periods=5.0)
        p3, p2 = float(loads.max()), float(r2.value)
        e_dcb = abs(p3 - p2) / p2
        extra.update({"dcb_peak_3d_N_m": p3, "dcb_peak_2d_N_m": p2, "error_dcb": e_dcb})
        err = max(err, e_dcb * 0.01 / 0.02)  # the DCB's 2 % tolerance on the case's 1 % scale
    return CaseResult("fem3d-bridge", "max |u_3D - u_2D| / max |u_2D| (elastic)", value, 0.0, err, 0.01,
                      time.perf_counter() - t0, extra)


# ----------------------------------------------------------------------------- cohesive: ENF
@register("fem3d-enf", "FEM 3D: cohesive end-notched flexure (mode II) as a plane-strain strip of hexahedra vs corrected beam theory's critical load")
def case_enf(overrides: dict) -> CaseResult:
    """Mode II: the 2D ``fem-enf`` specimen (fem_cases.case_enf: span 2L = 100 mm, arms h = 1.5 mm, starter
    crack a0 = L/2, Alfano & Crisfield's laminate, G_IIc = 2 G_Ic, the interface strength lowered so the
    cohesive zone spans about 3 elements, penalty 1e4 N/mm^3, loaded at mid-span to 1.6 x beam theory's
    critical deflection over 10 periods with 20 % mass-proportional damping) meshed with 200 x 1 x (2 + 2)
    hexahedra (0.5 mm along, 0.75 mm through, one across a 1 mm width held in y: plane strain) and 200
    cohesive elements, the 50 over the starter crack started fully damaged (its faces slide freely and only
    resist interpenetration). Critical load per unit width against beam theory, P_c = (4 / (3 a_e))
    sqrt(E' h^3 G_IIc), a_e = a0 + 0.42 chi h (fem_cases.enf_peak_load); tolerance 5 %."""
    from .fem_cases import AC2001, enf_peak_load

    t0 = time.perf_counter()
    _keys(overrides, ("nx", "nz", "periods"))
    d = AC2001
    L, h, width = 0.05, d["h"], 1e-3
    a0 = 0.5 * L
    nx = _opt(overrides, "nx", 200, int)
    nz = _opt(overrides, "nz", 2, int)
    gIIc = 2.0 * d["GIc"]
    l_e = 2 * L / nx
    tau = min(d["sigma"], math.sqrt(9 * math.pi * d["E2"] * gIIc / (32 * 3 * l_e)))
    C, rho, E_eff, chi = _ac2001_stiffness()
    m = gridmesh3d.split_box_mesh(nx, 1, nz, nz, 2 * L, width, h, h, bonded=(a0, 2 * L), precrack_contact=True)
    s = loop.build_state(m.X, m.hexes, [C], [rho], cfl=0.8, hourglass_ratio_max=0.5)
    loop.add_cohesive(s, m.cohesive, [1e13, tau, tau, d["GIc"], gIIc, 1.45], debonded=m.precrack)
    s.fix[1, :] = 1  # plane strain
    x = m.X
    tol = 1e-9 * L
    supports = (x[2] < -h + tol) & ((x[0] < tol) | (x[0] > 2 * L - tol))
    s.fix[2, supports] = 1
    s.fix[0, supports & (x[0] > L)] = 1
    load = (x[2] > h - tol) & (np.abs(x[0] - L) < tol)
    s.fix[0, load] = 1
    s.fix[2, load] = 1
    p_ref = enf_peak_load(E_eff, h, gIIc, a0 + 0.42 * chi * h)
    comp = (2 * L ** 3 + 3 * a0 ** 3) / (8 * E_eff * h ** 3)
    delta_max = 1.6 * p_ref * comp
    omega = (math.pi / (2 * L)) ** 2 * math.sqrt(E_eff * (2 * h) ** 2 / 12 / rho)
    t_end = _opt(overrides, "periods", 10.0) * 2 * math.pi / omega
    s.damping = 2 * 0.2 * omega

    def drive(st, vel):
        st.vp[2, load] = -vel

    def read(st):
        return float(st.X0[2, load].mean() - st.x[2, load].mean()), float(st.f[2, load].sum()) / width

    defl, loads = zip(*_displacement_control(s, delta_max, t_end, drive, read, "ENF 3D"))
    loads = _moving_average(np.array(loads))
    p_peak = float(loads.max())
    i_peak = int(np.argmax(loads))
    k_lin = float(np.polyfit(np.array(defl[: max(3, i_peak // 2)]), loads[: max(3, i_peak // 2)], 1)[0])
    e = loop.energies(s)
    return CaseResult("fem3d-enf", "critical load [N/m]", p_peak, p_ref, abs(p_peak - p_ref) / p_ref, 0.05,
                      time.perf_counter() - t0,
                      {"mesh": [nx, 1, nz, nz], "n_hexahedra": m.n_elems, "n_cohesive": m.n_cohesive,
                       "stiffness_N_per_m2": k_lin, "stiffness_beam_theory_N_per_m2": 1.0 / comp,
                       "interface_strength_Pa": tau, "steps": s.steps, "energy_error": e["energy_error"],
                       "debonded_grown": int((s.cstate[~m.precrack] > 0).sum()),
                       "load_drop_after_peak": float(1 - loads[-1] / p_peak)})


# ----------------------------------------------------------------------------- inelastic laws (solver.fem3d.laws3d)
def _law_si(deletion=True, ehm_failure=True):
    """The scene's default materials in SI (paraboloid matrix, plastic fibre) with the physics switches set; the
    2D quads' hourglass follows the material as the hexahedra's always does (solver.fem3d.hex8.hourglass_scale),
    so that the two engines' elements differ only in their dimension."""
    from types import SimpleNamespace

    from solver.scene import Scene

    si = Scene().si()
    si.numerics = SimpleNamespace(cfl=0.9, mass_scaling=1.0)
    si.physics = SimpleNamespace(element_deletion=deletion, fibre_plasticity=True, cohesive_interface=False,
                                 ehm_failure=ehm_failure, fibre_failure_at="centre", hourglass_follows_material=True)
    return si


def block_2d3d(material, strain_end, h=1e-3, rate=1e-4, samples=400, stop_at_failure=True):
    """One element loaded in uniaxial stress along x (plane strain: the 2D engine's out-of-plane axis is the
    3D y, held) in both engines with the same step: one quad and one hexahedron of side h, the face x = 0
    held in x (and one corner in the loading plane's other direction), the face x = h moved at the velocity
    that takes the engineering strain to ``strain_end`` (signed) at rate x the material's fastest wave speed
    over h (quasi-static). ``material``: 0 fibre (along x), 1 matrix, 2 EHM (axis 1 along x), the scene's
    default data. Returns a dict of histories: time, strain (engineering, along x), S11 of each engine
    (2nd Piola-Kirchhoff), their stress works, the 3D plastic history and each engine's failure (mode, time)."""
    from solver import fem
    from solver.fem.gridmesh import rect_mesh
    from solver.fem.materials import material_table
    from solver.fem3d import laws3d

    si = _law_si()
    p2 = material_table(si, 1.0, True, True)
    p2 = np.vstack([p2, p2[2]])  # a 4th row: the 2D engine keeps its EHM supports elastic only with 3 rows
    m2 = rect_mesh(1, 1, h, h, material=material)
    left = m2.x < 1e-12 * h
    right = m2.x > h * (1 - 1e-12)
    m2.fixed_x[left | right] = True
    m2.fixed_y[left & (m2.y < 1e-12 * h)] = True
    s2 = fem.build_state(m2, si, props=p2, hourglass_ratio_max=1.0)
    cmat, rho, props = laws3d.material_table3d(si)
    m3 = gridmesh3d.box_mesh(1, 1, 1, h, h, h)
    s3 = loop.build_state(m3.X, m3.hexes, cmat, rho, mat=[material], props=props, hourglass_ratio_max=1.0)
    X = m3.X
    s3.fix[1, :] = 1
    l3 = X[0] < 1e-12 * h
    r3 = X[0] > h * (1 - 1e-12)
    s3.fix[0, l3 | r3] = 1
    s3.fix[2, l3 & (X[2] < 1e-12 * h)] = 1
    c = float(max(s3.cmax[material], p2[material, 21]))
    v = np.sign(strain_end) * rate * c
    s2.vpx[right] = v
    s3.vp[0, r3] = v
    dt = 0.5 * min(fem.stable_dt(s2)[0], loop.stable_dt(s3))
    n = int(math.ceil(abs(strain_end) * h / abs(v) / dt))
    every = max(1, n // samples)
    out = {k: [] for k in ("time", "strain", "s2", "s3", "w2", "w3", "eqp3", "eqpt3", "epf3", "ep2")}
    fail2 = fail3 = None
    done = 0
    while done < n:
        k = min(every, n - done)
        if fail2 is None:
            r2 = fem.advance(s2, k, dt=dt)
            if r2.status != "ok":
                raise RuntimeError(f"block 2D: {r2}")
        if fail3 is None:
            r3r = loop.advance(s3, k, dt=dt, threads=1)
            if r3r.status != "ok":
                raise RuntimeError(f"block 3D: {r3r}")
        done += k
        if fail2 is None and s2.alive[0] == 0:
            fail2 = (int(s2.fail_mode[0]), float(s2.ev_t[0]))  # the 2D event log: the failing step's time
        if fail3 is None and s3.alive[0] == 0:
            fail3 = (int(s3.fail_mode[0]), float(s3.fail_time[0, 0]))
        if fail2 is not None or fail3 is not None:
            if stop_at_failure and fail2 is not None and fail3 is not None:
                break
            if stop_at_failure:
                continue
        out["time"].append(s3.time)
        out["strain"].append(float(s3.x[0, r3].mean() / h - 1.0))
        out["s2"].append(float(s2.stress[0, 0]))
        out["s3"].append(float(s3.pk2[0, 0]))
        out["w2"].append(float(s2.eint[0] * h))  # per unit thickness x the width h: the 3D element's work
        out["w3"].append(float(s3.eint[0]))
        out["eqp3"].append(float(s3.hist[0, laws3d.H3_EQP]))
        out["eqpt3"].append(float(s3.hist[0, laws3d.H3_EQPT]))
        out["epf3"].append(float(s3.hist[0, laws3d.H3_EPF]))
        out["ep2"].append(float(s2.eplast[0]))
    res = {k: np.asarray(a) for k, a in out.items()}
    res["fail2"], res["fail3"] = fail2, fail3
    res["deleted3_J"] = float(loop.energies(s3)["deleted"])
    res["deleted2_J"] = float(fem.energies(s2)["removed"] * h)
    res["energy_error3"] = float(loop.energies(s3)["energy_error"])
    res["si"] = si
    res["props3"] = props
    res["h"] = h
    return res


def crack_band_uniaxial(h=1e-3, rate=1e-4, samples=300):
    """One paraboloid-matrix hexahedron of side h in uniaxial stress along x (the face x = 0 held in x, three
    of its corners holding the rigid motions, every lateral face free) pulled through its crack band to
    deletion. Returns (the work it took to its deletion per crack area h^2 less the elastic energy at the
    yield point sigma_t^2 h / (2 E) (exact for the St. Venant-Kirchhoff law in uniaxial stress) [J/m^2], G_c,
    the failure mode, the energy error)."""
    from solver.fem3d import laws3d

    si = _law_si()
    cmat, rho, props = laws3d.material_table3d(si)
    m3 = gridmesh3d.box_mesh(1, 1, 1, h, h, h)
    s = loop.build_state(m3.X, m3.hexes, cmat, rho, mat=[1], props=props, hourglass_ratio_max=1.0)
    X = m3.X
    tol = 1e-12 * h
    l3 = X[0] < tol
    r3 = X[0] > h - tol
    s.fix[0, l3 | r3] = 1
    s.fix[1:, l3 & (X[1] < tol) & (X[2] < tol)] = 1
    s.fix[2, l3 & (X[1] > h - tol) & (X[2] < tol)] = 1
    s.fix[1, l3 & (X[1] < tol) & (X[2] > h - tol)] = 1
    v = rate * s.cmax[1]
    s.vp[0, r3] = v
    n = int(math.ceil(0.05 * h / v / loop.stable_dt(s)))
    every = max(1, n // samples)
    done = 0
    while done < n and s.alive[0]:
        rec = loop.advance(s, min(every, n - done), threads=1)
        if rec.status != "ok":
            raise RuntimeError(f"crack band 3D: {rec}")
        done += rec.steps
    e = loop.energies(s)
    w_el = si.matrix.sigma_u ** 2 / (2 * si.matrix.E) * h ** 3
    return (e["deleted"] - w_el) / (h * h), float(si.matrix.fracture_energy), int(s.fail_mode[0]), e["energy_error"]


def _curve_error(r):
    s2, s3 = r["s2"], r["s3"]
    return float(np.abs(s3 - s2).max() / max(np.abs(s2).max(), 1e-300))


@register("fem3d-laws-bridge", "FEM 3D vs 2D: inelastic laws on a plane-strain hexahedron (matrix paraboloid compression "
          "and crack band to failure, fibre compressive plasticity, EHM Hashin onset) against the 2D engine")
def case_laws_bridge(overrides: dict) -> CaseResult:
    """One hexahedron of side h = 1 mm held across its width (plane strain) against one quad of the 2D engine,
    same data, step and loading (:func:`block_2d3d`, uniaxial stress along x at 1e-4 of the wave speed, the
    compression at 5e-4):
    (a) the paraboloid matrix compressed to 45 % strain (past its plane-strain compressive yield near -1 GPa of S11, about 35 %) and pulled
    through its crack band to failure: S11 curves within 1 % of the largest stress (the error), failure
    (mode 4) at the same step; and, 3D only, the hexahedron in uniaxial stress (lateral faces free,
    :func:`crack_band_uniaxial`): the work from its stress peak to its deletion per crack area h^2 against G_c
    (``gc_error``, tolerance 3 %: the crack band's claim, made for uniaxial stress; in plane strain the
    lateral stress changes the plastic work, in both engines alike); (b) the fibre compressed along
    its axis to 3 % (yield at sigma_yc / E1 = 1.1 %): S11 curves and the plastic strain within 1 %; (c) the
    EHM pulled along its fibre axis to the Hashin fibre-tension mode (5): the failure strain of the two
    engines within 1 % and the 3D S11 at the last sample before it against XT = Vf Xt (1 %)."""
    t0 = time.perf_counter()
    _keys(overrides, ())
    errs, extra = {}, {}
    r = block_2d3d(1, -0.45, rate=5e-4)
    errs["matrix_compression"] = _curve_error(r)
    extra["matrix_compression_peak_Pa"] = float(np.abs(r["s3"]).max())
    extra["matrix_compression_eqp"] = float(r["eqp3"][-1])
    r = block_2d3d(1, 0.08)
    errs["matrix_tension"] = _curve_error(r)
    g_meas, gc, mode_u, ee_u = crack_band_uniaxial()
    extra.update(uniaxial_crack_band_mode=mode_u, uniaxial_energy_error=ee_u,
                 matrix_tension_fail_3d=r["fail3"], matrix_tension_fail_2d=r["fail2"],
                 gc_measured_J_m2=g_meas, gc_J_m2=gc, deleted_3d_J=r["deleted3_J"], deleted_2d_J=r["deleted2_J"],
                 energy_error_3d=r["energy_error3"])
    gc_err = abs(g_meas - gc) / gc
    extra["gc_error"] = gc_err
    if r["fail3"] is None or r["fail2"] is None or r["fail3"][0] != 4 or r["fail2"][0] != 4:
        errs["matrix_failure"] = 1.0
    else:
        errs["matrix_failure_time"] = abs(r["fail3"][1] - r["fail2"][1]) / r["fail2"][1]
    r = block_2d3d(0, -0.03)
    errs["fibre_compression"] = _curve_error(r)
    ep2, ep3 = r["ep2"][-1], r["epf3"][-1]
    errs["fibre_plastic_strain"] = abs(ep3 - ep2) / max(abs(ep2), 1e-300)
    extra.update(fibre_plastic_strain_3d=float(ep3), fibre_plastic_strain_2d=float(ep2))
    r = block_2d3d(2, 0.04)
    from solver.fem.materials import H_XT

    xt = float(r["props3"][2, H_XT])
    if r["fail3"] is None or r["fail2"] is None or r["fail3"][0] != 5 or r["fail2"][0] != 5:
        errs["ehm_failure"] = 1.0
    else:
        errs["ehm_failure_time"] = abs(r["fail3"][1] - r["fail2"][1]) / r["fail2"][1]
        errs["ehm_onset_vs_XT"] = abs(float(r["s3"][-1]) - xt) / xt
    extra.update(ehm_fail_3d=r["fail3"], ehm_fail_2d=r["fail2"], ehm_XT_Pa=xt,
                 ehm_s11_last_Pa=float(r["s3"][-1]))
    extra["errors"] = errs
    err = max(max(errs.values()), gc_err * 0.01 / 0.03)
    return CaseResult("fem3d-laws-bridge", "max relative difference 3D vs 2D (curves, failure times, plastic strain)",
                      max(errs.values()), 0.0, err, 0.01, time.perf_counter() - t0, extra)


def paraboloid_yield_points(angles=(0.4, -0.7, 1.1)):
    """The 3D law's first-yield load factor along four stress directions, each given in a frame rotated by
    ``angles`` (Euler z-y-x, rad) so all six global components are non-zero: uniaxial tension, uniaxial
    compression, pure shear and a triaxial state (s + p, p, p) with p = -sigma_t (a compressive pressure).
    The strain E = lambda C^-1 : sigma_dir is applied to a fresh history; lambda* (the largest load with no
    plastic flow) is found by bisection to 1e-13. Returns {name: (yield stress found, analytic)}: the uniaxial
    points sigma_t, sigma_c, the shear point sqrt(sigma_c sigma_t / 3), and the triaxial s solving
    2 s^2 + 2 (s + 3p)(sigma_c - sigma_t) - 2 sigma_c sigma_t = 0 (f of the module solver.fem.paraboloid)."""
    from solver.fem3d import laws3d

    si = _law_si()
    cmat, _, props = laws3d.material_table3d(si)
    st, sc = float(si.matrix.sigma_u), float(si.matrix.sigma_yc)
    a, b, c = angles
    Rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    Ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    Rx = np.array([[1, 0, 0], [0, math.cos(c), -math.sin(c)], [0, math.sin(c), math.cos(c)]])
    R = Rz @ Ry @ Rx
    Sinv = np.linalg.inv(cmat[1])
    p = -st
    # 2 s^2 + 2 (sc - st) s + (6 p (sc - st) - 2 sc st) = 0
    A, B, C = 2.0, 2 * (sc - st), 6 * p * (sc - st) - 2 * sc * st
    s_tri = (-B + math.sqrt(B * B - 4 * A * C)) / (2 * A)
    dirs = {"uniaxial tension": (np.diag([1.0, 0, 0]), st, np.zeros((3, 3))),
            "uniaxial compression": (np.diag([-1.0, 0, 0]), sc, np.zeros((3, 3))),
            "pure shear": (np.array([[0, 1.0, 0], [1.0, 0, 0], [0, 0, 0]]), math.sqrt(sc * st / 3), np.zeros((3, 3))),
            "triaxial (s+p, p, p)": (np.diag([1.0, 0, 0]), s_tri, p * np.eye(3))}
    out = {}
    for name, (D, ref, base) in dirs.items():
        def strain(lam):
            sig = R @ (base + lam * D) @ R.T
            sv = np.array([sig[0, 0], sig[1, 1], sig[2, 2], sig[0, 1], sig[1, 2], sig[2, 0]])
            e = Sinv @ sv  # engineering shears
            return np.array([e[0], e[1], e[2], 0.5 * e[3], 0.5 * e[4], 0.5 * e[5]])

        def flows(lam):
            hist = np.zeros(laws3d.N_HIST3)
            laws3d.law_point(props, cmat, 1, strain(lam), hist, 1e-9, False)
            return hist[laws3d.H3_EQP] > 0.0

        lo, hi = 0.0, 4.0 * sc
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if flows(mid):
                hi = mid
            else:
                lo = mid
            if hi - lo <= 1e-13 * hi:
                break
        out[name] = (lo, ref)
    return out


@register("fem3d-paraboloid-3d", "FEM 3D: the matrix's paraboloid law yields at the analytic uniaxial tension, compression, "
          "pure shear and triaxial points under rotated (fully 3D) stress states")
def case_paraboloid_3d(overrides: dict) -> CaseResult:
    """:func:`paraboloid_yield_points`: the largest relative difference between the load at first plastic flow
    of the 3D law (:mod:`solver.fem3d.laws3d`, through its strain -> stress map and the return mapping of
    :mod:`solver.fem.paraboloid`) and the analytic yield point, tolerance 1e-6."""
    t0 = time.perf_counter()
    _keys(overrides, ())
    pts = paraboloid_yield_points()
    errs = {k: abs(v - r) / r for k, (v, r) in pts.items()}
    err = max(errs.values())
    return CaseResult("fem3d-paraboloid-3d", "first-yield stress vs the analytic point (worst of four)", err, 0.0, err,
                      1e-6, time.perf_counter() - t0,
                      {"points_Pa": {k: [v, r] for k, (v, r) in pts.items()}, "errors": errs})


def deletion_bar(nx=8, h=1e-3, rate=2e-3, strain_end=0.06, law="paraboloid"):
    """A bar of nx x 1 x 1 matrix hexahedra (side h), one end held, the other pulled at rate x the wave speed
    until elements fail and are deleted and a while after (to ``strain_end`` of the bar). Returns (the state,
    the largest |residual| / scale over the run, the energies at the end)."""
    from solver.fem3d import laws3d

    si = _law_si()
    si.matrix.law = law
    cmat, rho, props = laws3d.material_table3d(si)
    m = gridmesh3d.box_mesh(nx, 1, 1, nx * h, h, h)
    s = loop.build_state(m.X, m.hexes, cmat, rho, mat=np.ones(nx, np.int32), props=props)
    L = nx * h
    left = m.X[0] < 1e-12 * h
    right = m.X[0] > L - 1e-12 * h
    s.fix[:, left] = 1
    s.fix[0, right] = 1
    v = rate * s.cmax[1]
    s.vp[0, right] = v
    s.v[0] = v * s.X0[0] / L  # started at the uniform strain rate (no step wave)
    n = int(math.ceil(strain_end * L / v / loop.stable_dt(s)))
    worst = 0.0
    done = 0
    while done < n:
        rec = loop.advance(s, min(200, n - done), threads=1)
        if rec.status != "ok":
            raise RuntimeError(f"deletion bar: {rec}")
        done += rec.steps
        e = loop.energies(s)
        worst = max(worst, e["energy_error"])
    return s, worst, loop.energies(s)


@register("fem3d-deletion-energy", "FEM 3D: energy balance of a matrix bar pulled until elements fail and are deleted")
def case_deletion_energy(overrides: dict) -> CaseResult:
    """:func:`deletion_bar` (8 paraboloid-matrix hexahedra of 1 mm, started at a uniform strain rate and pulled
    at 2e-3 of the wave speed to 6 %): elements fail (crack band, mode 4) and are deleted, their stored energy
    going to the 'deleted' account; the balance initial + external = internal + hourglass + kinetic + deleted
    holds with the largest residual over the run below 1e-2 of the energy in play. Before the first deletion
    the residual is about 3e-5 (the plastic flow alone); it grows to a few 1e-3 while the crack bands soften,
    the same with deletion off (the deletion's booking adds nothing), then swings by about half its size from
    sample to sample, as the integer-step kinetic energy of a bar ringing at its highest frequencies does.
    Halving the CFL halves it (4.2e-3 -> 1.8e-3 on 100-step samples); its cause is not pinned down further."""
    t0 = time.perf_counter()
    _keys(overrides, ())
    s, worst, e = deletion_bar()
    from solver.fem3d.guard3d import failure_report

    nd = int((s.alive == 0).sum())
    err = worst if nd > 0 else 1.0
    return CaseResult("fem3d-deletion-energy", "largest |energy residual| / energy in play", worst, 0.0, err, 1e-2,
                      time.perf_counter() - t0, {"deleted": nd, "failures": failure_report(s),
                                                  "energies_J": {k: float(v) for k, v in e.items()}})
