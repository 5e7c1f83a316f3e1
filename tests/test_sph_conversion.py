"""FEM-to-SPH conversion bookkeeping (solver.sph.conversion) on meshes built here.

The FEM engine is not involved: the nodes of the surviving elements simply drift with their
velocities (no forces) while converted particles follow SPH, so every conservation statement below
must hold to round-off for the conversion and the SPH step alone.
"""

import math

import numpy as np
import pytest

from solver.sph import conversion as cv
from solver.sph import loop, materials as mt, particles as pp


def _mesh(nx=12, ny=4, a=1e-6, rho=1280.0, rng=None, angle=0.0):
    xs, ys = np.meshgrid(np.arange(nx + 1) * a, np.arange(ny + 1) * a, indexing="ij")
    X0, Y0 = xs.ravel().copy(), ys.ravel().copy()
    nid = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    quads = np.array([[nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]]
                      for i in range(nx) for j in range(ny)], np.int64)
    c, s = math.cos(angle), math.sin(angle)
    x, y = c * X0 - s * Y0, s * X0 + c * Y0  # current configuration: a rigid rotation
    elem_mass = np.full(len(quads), rho * a * a)
    node_mass = np.zeros(X0.size)
    for e, q in enumerate(quads):
        node_mass[q] += 0.25 * elem_mass[e]
    material = np.where(np.arange(len(quads)) % 3 == 0, 0, 1).astype(np.int8)  # fibre and matrix
    return dict(X0=X0, Y0=Y0, x=x, y=y, quads=quads, elem_mass=elem_mass, node_mass=node_mass,
                material=material, a=a)


def _conversion(m, D0=0.5):
    mats = mt.table(mt.transversely_isotropic(294e9, 14e9, 28e9, 0.2, 0.25, 1800.0, D0=D0, kappa_f=0.02),
                    mt.isotropic(2.96e9, 0.4, 1280.0, D0=D0, kappa_f=0.025))
    prm = pp.make_params(m["a"])
    return cv.build_dormant(m["material"], np.array([True, True]), mats, prm)


def _totals(m, P, vx, vy):
    a = P.active_indices()
    mass = m["node_mass"].sum() + P.F[pp.M, a].sum()
    px = (m["node_mass"] * vx).sum() + (P.F[pp.M, a] * P.F[pp.VX, a]).sum()
    py = (m["node_mass"] * vy).sum() + (P.F[pp.M, a] * P.F[pp.VY, a]).sum()
    ke = 0.5 * (m["node_mass"] * (vx**2 + vy**2)).sum() + P.energies()["kinetic"]
    return mass, px, py, ke


def test_no_conversion_allocates_nothing():
    m = _mesh()
    none = np.array([False, False, False])
    assert cv.build_dormant(m["material"], none, np.zeros((3, 8)), pp.make_params(1e-6)) is None


def test_activation_moves_mass_momentum_stress_and_axes():
    rng = np.random.default_rng(3)
    m = _mesh(angle=0.3)
    C = _conversion(m)
    P = C.particles
    assert P.n == len(m["quads"]) and P.n_act == 0  # dormant: none in the neighbour search
    vx = rng.normal(0, 2.0, m["x"].size)
    vy = rng.normal(0, 2.0, m["x"].size)
    ne = len(m["quads"])
    sxx, syy, sxy = rng.normal(0, 1e7, (3, ne))
    theta0 = rng.uniform(0, math.pi, ne)
    alive = np.ones(ne, np.uint8)
    mass0, px0, py0, ke0 = _totals(m, P, vx, vy)
    dead = np.array([0, 5, 6, 7, 20, 21, 33])
    alive[dead] = 0
    n = C.convert(alive, m["quads"], m["X0"], m["Y0"], m["x"], m["y"], vx, vy, m["node_mass"], m["elem_mass"],
                  sxx, syy, sxy, theta0)
    assert n == dead.size and P.n_act == dead.size
    mass1, px1, py1, ke1 = _totals(m, P, vx, vy)
    scale = np.sum(m["node_mass"] * 0 + m["elem_mass"].sum()) * 2.0
    assert mass1 == pytest.approx(mass0, rel=1e-14)
    assert abs(px1 - px0) <= 1e-14 * scale and abs(py1 - py0) <= 1e-14 * scale
    assert P.e_conversion >= 0.0
    assert ke1 + P.e_conversion == pytest.approx(ke0, rel=1e-12)  # the jump is booked
    for e in dead:
        p = int(np.flatnonzero(C.particle_elem == e)[0])
        assert C.elem_particle[e] == -1  # converted: no dormant particle left in the element
        q = m["quads"][e]
        assert P.F[pp.X, p] == pytest.approx(m["x"][q].mean()) and P.F[pp.VY, p] == pytest.approx(vy[q].mean())
        assert P.F[pp.M, p] == m["elem_mass"][e]
        assert P.F[pp.RHO, p] == pytest.approx(1280.0, rel=1e-12)  # rigid motion: area unchanged
        assert (P.F[pp.SXX, p], P.F[pp.SYY, p], P.F[pp.SXY, p]) == (sxx[e], syy[e], sxy[e])
        assert P.F[pp.THETA, p] == pytest.approx(theta0[e] + 0.3, abs=1e-12)  # axes rotated with the body
    # converting again changes nothing
    assert C.convert(alive, m["quads"], m["X0"], m["Y0"], m["x"], m["y"], vx, vy, m["node_mass"],
                     m["elem_mass"], sxx, syy, sxy, theta0) == 0


def test_nodes_of_fully_converted_elements_lose_all_mass():
    m = _mesh(nx=3, ny=1)
    C = _conversion(m)
    alive = np.zeros(3, np.uint8)
    z = np.zeros(m["x"].size)
    C.convert(alive, m["quads"], m["X0"], m["Y0"], m["x"], m["y"], z, z, m["node_mass"], m["elem_mass"],
              np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    assert np.all(m["node_mass"] == 0.0)
    assert C.particles.F[pp.M].sum() == pytest.approx(m["elem_mass"].sum(), rel=1e-15)


def _drift_and_step(m, C, vx, vy, n_steps, dt):
    """Nodes drift force-free; the active particles take SPH steps."""
    for _ in range(n_steps // 10):
        m["x"] += 10 * dt * vx
        m["y"] += 10 * dt * vy
        if C.particles.n_act:
            rep = loop.step_chunk(C.particles, 10, dt)
            assert rep.status == "ok", rep.finding


def test_bar_converting_mid_run_conserves_mass_and_momentum():
    rng = np.random.default_rng(11)
    m = _mesh(nx=30, ny=6)
    C = _conversion(m, D0=0.8)
    P = C.particles
    ne = len(m["quads"])
    vx = 0.5 + rng.normal(0, 0.3, m["x"].size)
    vy = rng.normal(0, 0.3, m["x"].size)
    sxx, syy, sxy = rng.normal(0, 3e7, (3, ne))
    theta0 = np.where(m["material"] == 0, 0.0, 0.0)
    alive = np.ones(ne, np.uint8)
    mass0, px0, py0, _ = _totals(m, P, vx, vy)
    dt = 0.2 * m["a"] / 12000.0
    for batch in (np.arange(0, ne, 2), np.arange(1, ne, 4)):  # two waves of failures, mid-run
        _drift_and_step(m, C, vx, vy, 50, dt)
        alive[batch] = 0
        C.convert(alive, m["quads"], m["X0"], m["Y0"], m["x"], m["y"], vx, vy, m["node_mass"], m["elem_mass"],
                  sxx, syy, sxy, theta0)
        mass, px, py, _ = _totals(m, P, vx, vy)
        assert mass == pytest.approx(mass0, rel=1e-14)
    _drift_and_step(m, C, vx, vy, 200, dt)
    mass, px, py, _ = _totals(m, P, vx, vy)
    pscale = float(np.sum(m["elem_mass"]) * (np.abs(vx).max() + np.abs(P.F[pp.VX]).max()))
    assert P.n_act == C.n_converted > ne // 2
    assert mass == pytest.approx(mass0, rel=1e-14)
    assert abs(px - px0) < 1e-12 * pscale and abs(py - py0) < 1e-12 * pscale
    assert np.all(np.isfinite(P.F[pp.X, P.active_indices()]))


def test_converted_particles_at_rest_in_an_unloaded_body_stay_at_rest():
    m = _mesh(nx=16, ny=6)
    C = _conversion(m, D0=0.1)
    ne = len(m["quads"])
    z = np.zeros(m["x"].size)
    alive = np.ones(ne, np.uint8)
    alive[(np.arange(ne) // 6) % 2 == 0] = 0  # every other column of elements converts
    zero = np.zeros(ne)
    C.convert(alive, m["quads"], m["X0"], m["Y0"], m["x"], m["y"], z, z, m["node_mass"], m["elem_mass"],
              zero, zero, zero, zero)
    P = C.particles
    a = P.active_indices()
    x0, y0 = P.F[pp.X, a].copy(), P.F[pp.Y, a].copy()
    rep = loop.step_chunk(P, 300, 0.2 * m["a"] / 12000.0)
    assert rep.status == "ok"
    assert np.all(P.F[pp.VX, a] == 0.0) and np.all(P.F[pp.VY, a] == 0.0)
    assert np.all(P.F[pp.X, a] == x0) and np.all(P.F[pp.Y, a] == y0)
    assert P.e_conversion == 0.0


def test_a_crushed_element_converts_to_powder_not_to_an_exploding_particle():
    """An element crushed to a tenth of its area (the engine erodes such elements) or with a non-finite
    stress converts to a fully fractured particle with no stress and at most twice its reference
    density; a healthy neighbour converts with its own stress and density."""
    m = _mesh(nx=3, ny=1)
    q = m["quads"][1]
    top = q[np.argsort(m["y"][q])[2:]]
    m["y"][top] -= 0.9 * m["a"]  # element 1's top edge pushed down to 10 % of its height
    C = _conversion(m)
    P = C.particles
    alive = np.array([1, 0, 0], np.uint8)
    sxx = np.array([0.0, 5e9, 1e7])
    syy = np.array([0.0, np.inf, 2e7])
    z = np.zeros(m["x"].size)
    C.convert(alive, m["quads"], m["X0"], m["Y0"], m["x"], m["y"], z, z, m["node_mass"], m["elem_mass"],
              sxx, syy, np.zeros(3), np.zeros(3))
    crushed, healthy = (int(np.flatnonzero(C.particle_elem == e)[0]) for e in (1, 2))
    assert P.F[pp.DMG, crushed] == 1.0 and P.F[pp.SXX, crushed] == 0.0 and P.F[pp.SYY, crushed] == 0.0
    assert P.F[pp.RHO, crushed] == pytest.approx(2 * 1280.0, rel=1e-12)
    assert all(np.isfinite(P.F[r, crushed]) for r in (pp.X, pp.Y, pp.VX, pp.VY, pp.M, pp.RHO, pp.SXX, pp.SYY, pp.SXY, pp.THETA))
    assert P.F[pp.DMG, healthy] == 0.0 and P.F[pp.SYY, healthy] == 2e7
