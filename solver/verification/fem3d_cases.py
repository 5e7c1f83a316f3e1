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

Overrides (``--set``): ``nx`` (elements along), per case ``periods``; an unknown name is rejected.
"""

from __future__ import annotations

import math
import time

import numpy as np

from solver.fem3d import gridmesh3d, loop, material3d

from . import CaseResult, register
from .fem_cases import _crossing, _keys, _opt

#: one thread below this many elements (waking the other threads costs more than it gains)
SMALL = 4000


def _threads(state):
    return 1 if state.hexes.shape[0] < SMALL else None


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
    x1, x2 = 0.25 * length, 0.75 * length
    n1 = groups[int(round(nx / 4))]
    n2 = groups[int(round(3 * nx / 4))]
    t_end = 0.9 * length / c_pred
    ts, v1, v2 = [], [], []
    while s.time < t_end:
        rec = loop.advance(s, 2, threads=_threads(s))
        if rec.status != "ok":
            raise RuntimeError(f"wave case: {rec}")
        ts.append(s.time)
        v1.append(float((p @ s.v[:, n1]).mean()))
        v2.append(float((p @ s.v[:, n2]).mean()))
    t1 = _crossing(np.array(ts), np.array(v1), 0.5 * v0)
    t2 = _crossing(np.array(ts), np.array(v2), 0.5 * v0)
    c = (x2 - x1) / (t2 - t1)
    return (c if math.isfinite(c) else math.inf), s


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
    s = loop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(E, nu)], [rho])
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
        rec = loop.advance(s, every, threads=_threads(s))
        if rec.status != "ok":
            raise RuntimeError(f"cantilever: {rec}")
        e = loop.energies(s)
        ts.append(s.time)
        us.append(float((s.x[2, tips] - s.X0[2, tips]).mean()))
        es.append(e["kinetic"] + e["internal"] + e["hourglass"])
    ts, us = np.array(ts), np.array(us)
    z = np.nonzero((us[:-1] > 0) & (us[1:] <= 0))[0]
    tz = ts[z] + (ts[z + 1] - ts[z]) * us[z] / (us[z] - us[z + 1])
    period = float(np.diff(tz).mean()) if tz.size >= 2 else math.nan
    return period, T, np.array(es), s


@register("fem3d-cantilever", "FEM 3D: first bending period of a clamped beam (L/H = 20), 2 and 3 hexahedra through the thickness, vs Euler-Bernoulli")
def case_cantilever(overrides: dict) -> CaseResult:
    t0 = time.perf_counter()
    _keys(overrides, ("nx", "periods"))
    nx = _opt(overrides, "nx", 20, int)
    periods = _opt(overrides, "periods", 2.2)
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
    _keys(overrides, ("nx", "periods"))
    nx = _opt(overrides, "nx", 20, int)
    periods = _opt(overrides, "periods", 10.0)
    _, T, es, s = cantilever(nx, 2, periods, samples=40)
    drift = float(np.abs(es - es[0]).max() / es[0])
    return CaseResult("fem3d-energy", "max |E(t) - E(0)| / E(0)", drift, 0.0, drift, 1e-3, time.perf_counter() - t0,
                      {"periods": periods, "steps": s.steps, "energy_error": loop.energies(s)["energy_error"]})
