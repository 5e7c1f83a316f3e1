"""The 3D hexahedron (solver/fem3d): the element's properties checked directly, the elastic laws, and the
verification cases of solver/verification/fem3d_cases.py at small sizes (their tolerances are the cases' own)."""

import math

import numpy as np
import pytest

from solver.fem3d import gridmesh3d, hex8, loop, material3d
from solver.verification import load_cases

CASES = load_cases()
GP = 1 / math.sqrt(3)


def _distorted(seed=0, scale=1e-3):
    rng = np.random.default_rng(seed)
    return (0.5 * hex8.XI + rng.uniform(-0.15, 0.15, (8, 3)) + 1.0) * scale  # (8, 3)


def _one_element(X8, C=None, rho=1500.0):
    C = material3d.isotropic_stiffness(70e9, 0.3) if C is None else C
    return loop.build_state(np.ascontiguousarray(X8.T), np.arange(8)[None, :], [C], [rho])


def _gauss_mean_gradient(X8):
    """(1/V) int dN/dx dV and V by 2x2x2 Gauss (exact for the trilinear hexahedron)."""
    B = np.zeros((3, 8))
    V = 0.0
    for p in [(a, b, c) for a in (-GP, GP) for b in (-GP, GP) for c in (-GP, GP)]:
        f = 1 + hex8.XI * np.array(p)
        dN = np.stack([hex8.XI[:, 0] * f[:, 1] * f[:, 2], hex8.XI[:, 1] * f[:, 0] * f[:, 2],
                       hex8.XI[:, 2] * f[:, 0] * f[:, 1]], axis=1) / 8
        J = X8.T @ dN
        dJ = np.linalg.det(J)
        V += dJ
        B += (dN @ np.linalg.inv(J)).T * dJ
    return B / V, V


def test_b_matrix_is_flanagan_belytschkos_exact_mean_gradient():
    X8 = _distorted(1)
    B, V = hex8.fb_gradient(X8[:, 0].copy(), X8[:, 1].copy(), X8[:, 2].copy())
    bg, vg = _gauss_mean_gradient(X8)
    assert abs(V - vg) < 1e-13 * vg
    assert np.abs(B / V - bg).max() < 1e-10 * np.abs(bg).max()
    s = _one_element(X8)
    assert np.allclose(s.b0[0].reshape(3, 8), bg, rtol=0, atol=1e-10 * np.abs(bg).max())
    assert np.allclose(bg @ X8, np.eye(3), atol=1e-12)  # sum_I b_iI X_jI = delta_ij


def test_rigid_motion_gives_zero_strain_rate_and_zero_force():
    X8 = _distorted(2)
    s = _one_element(X8)
    R = material3d.fibre_frame([1.0, -2.0, 0.7])  # a proper rotation (det +1)
    assert np.linalg.det(R) > 0
    x8 = X8 @ R.T + np.array([0.3, -0.1, 2.0]) * 1e-3
    s.x[:] = x8.T
    f = loop.nodal_forces(s)
    # the force scale of a 1e-3 strain of this element
    s.x[:] = (X8 @ (np.eye(3) + 1e-3 * np.diag([1.0, -0.5, 0.2])).T).T
    scale = np.abs(loop.nodal_forces(s)).max()
    assert np.abs(f).max() < 1e-9 * scale
    w = np.array([0.3, -1.2, 2.0])
    v = np.cross(w, x8) + np.array([1.0, 2.0, -3.0])  # rigid velocity field at the rotated configuration
    L = hex8.velocity_gradient(x8, v)
    assert np.abs(0.5 * (L + L.T)).max() < 1e-10 * np.abs(L).max()
    assert np.allclose(0.5 * (L - L.T), np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]), atol=1e-10)


def test_hourglass_vectors_are_orthogonal_to_linear_fields():
    X8 = _distorted(3)
    s = _one_element(X8)
    g = hex8.gamma_vectors(s.b0[0], s.hx[0])
    assert np.abs(g.sum(axis=1)).max() < 1e-14
    assert np.abs(g @ X8).max() < 1e-14 * np.abs(X8).max()
    # on a box they are the base vectors / 8, and they pick out their own mode
    box = gridmesh3d.box_mesh(1, 1, 1, 2.0, 1.0, 0.5)
    sb = loop.build_state(box.X[:, box.hexes[0]], np.arange(8)[None, :], [material3d.isotropic_stiffness(1.0, 0.3)], [1.0])
    gb = hex8.gamma_vectors(sb.b0[0], sb.hx[0])
    assert np.allclose(gb, hex8.HG / 8, atol=1e-14)
    assert np.allclose(gb @ hex8.HG.T, np.eye(4), atol=1e-14)


def test_nodal_forces_sum_to_zero_for_any_deformation():
    X8 = _distorted(4)
    E1, E2, G12, nu12, nu23 = 294e9, 15e9, 15e9, 0.2, 0.4
    s = _one_element(X8, material3d.fibre_stiffness(E1, E2, G12, nu12, nu23, [1.0, 1.0, 0.5]))
    rng = np.random.default_rng(5)
    s.x[:] = s.X0 + rng.uniform(-3e-5, 3e-5, s.X0.shape)  # with hourglass modes
    f = loop.nodal_forces(s)
    assert np.abs(f).max() > 0
    assert np.abs(f.sum(axis=1)).max() < 1e-12 * np.abs(f).max()


def test_pure_bending_of_one_element_stores_the_beams_energy():
    """u1 = -k x z with the free anticlastic strain u2 = nu k y z: W = E I k^2 L / 2 exactly (the assumed-strain
    bending block; the one-point part sees nothing)."""
    E, nu = 1.0e9, 0.3
    box = gridmesh3d.box_mesh(1, 1, 1, 2.0, 1.0, 0.5, origin=(-1.0, -0.5, -0.25))
    X = box.X[:, box.hexes[0]]
    s = loop.build_state(X, np.arange(8)[None, :], [material3d.isotropic_stiffness(E, nu)], [1.0])
    k = 1e-7
    s.x[0] = X[0] - k * X[0] * X[2]
    s.x[1] = X[1] + nu * k * X[1] * X[2]
    loop.advance(s, 1, dt=1e-12)
    e = loop.energies(s)
    ref = 0.5 * E * (1.0 * 0.5 ** 3 / 12) * k * k * 2.0
    assert abs(e["internal"]) < 1e-6 * ref
    assert e["hourglass"] == pytest.approx(ref, rel=1e-6)


def test_transversely_isotropic_stiffness_turned_with_its_fibre():
    E1, E2, G12, nu12, nu23, rho = 294e9, 15e9, 15e9, 0.2, 0.4, 1800.0
    C0 = material3d.transversely_isotropic_stiffness(E1, E2, G12, nu12, nu23)
    S0 = np.linalg.inv(C0)
    assert S0[0, 0] == pytest.approx(1 / E1) and S0[1, 1] == pytest.approx(1 / E2)
    assert S0[3, 3] == pytest.approx(1 / G12) and S0[4, 4] == pytest.approx(2 * (1 + nu23) / E2)
    d = material3d.fibre_direction(0.4, -0.3)
    C = material3d.fibre_stiffness(E1, E2, G12, nu12, nu23, d)
    speeds, pol = material3d.wave_speeds(C, rho, d)
    assert speeds[0] == pytest.approx(math.sqrt(C0[0, 0] / rho), rel=1e-12)  # along the fibre: sqrt(C11/rho)
    assert abs(abs(pol[:, 0] @ d) - 1) < 1e-12
    # the uniaxial modulus along the fibre is E1 whatever the orientation
    Sg = np.linalg.inv(C)
    n = np.array([d[0] ** 2, d[1] ** 2, d[2] ** 2, d[0] * d[1], d[1] * d[2], d[2] * d[0]])  # sigma = d (x) d
    assert 1 / (n @ Sg @ n) == pytest.approx(E1, rel=1e-10)  # eps_dd = n . (S sigma), engineering shears
    assert material3d.max_wave_speed(C, rho) == pytest.approx(speeds[0], rel=1e-6)
    # the compiled law: S = C : E (tensor shears in)
    Ev = np.array([1e-3, -2e-4, 3e-4, 1e-4, -2e-4, 5e-5])
    S = material3d.stress_from_strain(C[None], 0, Ev)
    assert np.allclose(S, C @ (Ev * np.array([1, 1, 1, 2, 2, 2])), rtol=1e-13)


def test_isotropic_wave_speeds():
    E, nu, rho = 200e9, 0.3, 7800.0
    C = material3d.isotropic_stiffness(E, nu)
    sp, _ = material3d.wave_speeds(C, rho, [1.0, 2.0, -0.5])
    mu = E / (2 * (1 + nu))
    assert sp[0] == pytest.approx(math.sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu) * rho)), rel=1e-12)
    assert sp[1] == pytest.approx(math.sqrt(mu / rho), rel=1e-12)


def test_distorted_box_mesh_keeps_positive_volumes_and_the_mass():
    m = gridmesh3d.box_mesh(4, 3, 2, 4.0, 3.0, 2.0, perturb=0.3, seed=1)
    s = loop.build_state(m.X, m.hexes, [material3d.isotropic_stiffness(1.0, 0.25)], [2.0])
    assert s.vol0.min() > 0
    assert s.vol0.sum() == pytest.approx(24.0, rel=1e-12)
    assert s.mass.sum() == pytest.approx(48.0, rel=1e-12)


def test_stable_step_holds_a_random_vibration_of_a_distorted_mesh():
    """Every mode excited (random velocities), an oblique fibre, distorted hexahedra: at the stable step the
    energy stays bounded and balanced."""
    m = gridmesh3d.box_mesh(4, 4, 4, 1e-3, 1e-3, 1e-3, perturb=0.25, seed=2)
    C = material3d.fibre_stiffness(294e9, 15e9, 15e9, 0.2, 0.4, [1.0, 0.5, 0.3])
    s = loop.build_state(m.X, m.hexes, [C], [1800.0], cfl=1.0)
    s.v[:] = np.random.default_rng(3).uniform(-1.0, 1.0, s.v.shape)
    loop.advance(s, 2000)
    e = loop.energies(s)
    assert e["energy_error"] < 0.02, e
    assert e["kinetic"] + e["internal"] + e["hourglass"] < 1.05 * e["initial"]


def test_external_force_work_and_viscous_hourglass_are_booked():
    """A cantilever loaded at its tip, with viscous hourglass damping: initial + external work = held + the
    hourglass forces' (partly dissipated) work."""
    m = gridmesh3d.box_mesh(10, 1, 2, 0.1, 0.01, 0.01)
    s = loop.build_state(m.X, m.hexes, [material3d.isotropic_stiffness(2e6, 0.3)], [1000.0], hourglass_damping=0.2)
    s.fix[:, m.X[0] < 1e-12] = 1
    tip = m.X[0] > 0.1 - 1e-12
    s.fext[2, tip] = -1e-3
    loop.advance(s, 3000)
    e = loop.energies(s)
    assert e["external"] > 0
    assert e["energy_error"] < 1e-3, e


def test_tied_nodes_move_together():
    m = gridmesh3d.box_mesh(3, 1, 1, 3.0, 1.0, 1.0)
    s = loop.build_state(m.X, m.hexes, [material3d.isotropic_stiffness(1.0, 0.3)], [1.0])
    i = np.arange(4)
    groups = np.stack([m.node(i, 0, 0), m.node(i, 1, 0), m.node(i, 0, 1), m.node(i, 1, 1)], axis=1)
    loop.tie_nodes(s, groups)
    s.v[:, groups[3]] = np.array([[0.1], [0.05], [-0.02]])
    loop.tie_nodes(s, groups)  # re-tie: slaves take the master's velocity
    loop.advance(s, 50)
    for g in groups:
        assert np.allclose(s.v[:, g], s.v[:, g[:1]], atol=0)
        assert np.allclose(s.x[:, g] - s.X0[:, g], (s.x[:, g] - s.X0[:, g])[:, :1], atol=1e-15)


def run(name, **overrides):
    res = CASES[name][0](overrides)
    assert res.wall_time_s >= 0
    return res


def test_fem3d_cases_registered():
    for name in ("fem3d-wave-iso", "fem3d-wave-fibre", "fem3d-patch", "fem3d-cantilever", "fem3d-energy"):
        assert name in CASES


def test_fem3d_wave_speed_isotropic():
    res = run("fem3d-wave-iso", nx=120)
    assert res.passed, res


def test_fem3d_wave_speed_through_an_oblique_fibre_is_christoffels():
    res = run("fem3d-wave-fibre", nx=120)
    assert res.passed, res


def test_fem3d_patch_constant_stress_to_round_off():
    res = run("fem3d-patch")
    assert res.details["stress_error"] < 1e-10 and res.details["interior_force_ratio"] < 1e-10, res.details
    assert res.passed


def test_fem3d_cantilever_period_with_two_and_three_elements_through_the_thickness():
    res = run("fem3d-cantilever", periods=1.7)
    assert res.details["error_2_through_thickness"] < 0.03 and res.details["error_3_through_thickness"] < 0.03, res.details
    assert res.passed


def test_fem3d_free_vibration_conserves_energy():
    res = run("fem3d-energy", periods=10)
    assert res.value < 1e-3, res


def test_bench_fem_dim_3_from_the_cli(capsys):
    from cli.main import main

    assert main(["bench", "fem", "--dim", "3", "--threads", "1", "--sizes", "300", "--json"]) == 0
    import json

    rows = json.loads(capsys.readouterr().out)
    assert rows[0]["dim"] == 3 and rows[0]["status"] == "ok" and rows[0]["element_updates_per_s"] > 0
    assert main(["bench", "analytic", "--dim", "3", "--sizes", "300"]) == 2  # not a benchmark


def test_a_spinning_vibrating_block_keeps_its_energy_over_three_turns():
    """Large rotations: a distorted block of oblique fibre spins three turns while it bends (hourglass modes
    in play); the total energy stays within 1e-4 (the stress is total-Lagrangian, the hourglass forces turn
    with the polar rotation)."""
    m = gridmesh3d.box_mesh(6, 2, 2, 6e-3, 2e-3, 2e-3, origin=(-3e-3, -1e-3, -1e-3), perturb=0.2, seed=1)
    C = material3d.fibre_stiffness(294e9, 15e9, 15e9, 0.2, 0.4, [1.0, 0.5, 0.3])
    s = loop.build_state(m.X, m.hexes, [C], [1800.0])
    w = np.array([0.0, 0.0, 2e5])
    s.v[:] = np.cross(w, s.X0.T).T
    s.v[2] += 5.0 * np.sin(np.pi * s.X0[0] / 6e-3)
    turn = 2 * np.pi / np.linalg.norm(w)
    loop.advance(s, int(3 * turn / loop.stable_dt(s)))
    e = loop.energies(s)
    assert s.time > 2.9 * turn
    assert e["energy_error"] < 1e-4, e
    assert 0 < e["hourglass"] < 0.01 * e["kinetic"], e



def _bent_fibre_block(squeeze, then=None):
    """One fibre element (the 3D quick scene's fibre law, fibre along x) squeezed uniformly along the fibre by
    ``squeeze`` and bent by u1 = -k x z (and then, if given, squeezed by ``then`` instead with the bend kept,
    then the bend released); its hourglass energy, centre secant ratio |S| / |C : E| and the law."""
    from solver.fem3d.laws3d import material_table3d
    from solver.scene import load_scene

    cmat, rho, props = material_table3d(load_scene("seed-0deg-fem3d-quick").si())
    box = gridmesh3d.box_mesh(1, 1, 1, 2e-6, 1e-6, 1e-6, origin=(-1e-6, -0.5e-6, -0.5e-6))
    X = box.X[:, box.hexes[0]]
    s = loop.build_state(X, np.arange(8)[None, :], cmat[:1], rho[:1], props=props[:1], deletion=False)
    k = 1e-3 / 0.5e-6  # 0.1 % bending strain at the top and bottom faces
    s.x[0] = X[0] * (1.0 - squeeze) - k * X[0] * X[2]
    loop.advance(s, 1, dt=1e-15)
    if then is not None:  # the squeeze changed, the bend kept; then the bend released
        s.x[0] = X[0] * (1.0 - then) - k * X[0] * X[2]
        loop.advance(s, 1, dt=1e-15)
        s.x[0] = X[0] * (1.0 - then)
        loop.advance(s, 1, dt=1e-15)
    trial = material3d.stress_from_strain(cmat, 0, s.strain[0].copy())
    w = np.array([1, 1, 1, 2, 2, 2.0])
    t2 = np.sum(w * trial ** 2)
    secant = math.sqrt(np.sum(w * s.pk2[0] ** 2) / t2) if t2 > 0 else 1.0  # no centre strain: elastic
    return loop.energies(s)["hourglass"], secant, props[0]


def test_hourglass_stiffness_follows_the_centres_secant_ratio():
    """An element whose centre flows (a fibre squeezed past its compressive yield strain) resists the bending
    mode with its centre's secant ratio |S| / |C : E| times the elastic stiffness, but never less than
    quad.HOURGLASS_SECANT_FLOOR times it; an elastic centre with the elastic stiffness (hex8.hourglass_scale)."""
    from solver.fem.materials import PLASTIC, SYC
    from solver.fem.quad import HOURGLASS_SECANT_FLOOR
    from solver.fem3d.laws3d import CF11

    hg_free, s_free, p = _bent_fibre_block(0.0)
    assert p[PLASTIC] > 0 and s_free == pytest.approx(1.0, abs=1e-12) and hg_free > 0
    eps_y = p[SYC] / p[CF11]  # the fibre's compressive yield strain (uniaxial strain)
    hg_elastic, s_el, _ = _bent_fibre_block(0.5 * eps_y)
    assert s_el == pytest.approx(1.0, abs=1e-9)
    assert hg_elastic == pytest.approx(hg_free, rel=1e-6)  # the bending mode does not see a uniform squeeze
    hg_flow, s_flow, _ = _bent_fibre_block(1.4 * eps_y)
    assert HOURGLASS_SECANT_FLOOR < s_flow < 0.9  # the centre has flowed, above the floor
    assert hg_flow == pytest.approx(s_flow * hg_free, rel=1e-3)
    hg_plastic, s_pl, _ = _bent_fibre_block(3.0 * eps_y)
    assert s_pl < 0.9 * HOURGLASS_SECANT_FLOOR  # flowed further: the floor binds
    assert hg_plastic == pytest.approx(HOURGLASS_SECANT_FLOOR * hg_free, rel=1e-3)


def test_hourglass_stiffness_does_not_recover_when_the_centre_unloads():
    """Squeezed past yield and bent, then the squeeze released (the centre's secant ratio would be back at 1)
    and the bend released: the element keeps the smallest ratio it had, so the bending mode gives back what
    it took, and no more (with the factor back at 1 it would give back twice as much: energy created)."""
    from solver.fem.materials import SYC
    from solver.fem3d.laws3d import CF11

    hg_free, _, p = _bent_fibre_block(0.0)
    eps_y = p[SYC] / p[CF11]
    hg_plastic, s_pl, _ = _bent_fibre_block(3.0 * eps_y)
    assert 0 < hg_plastic < 0.6 * hg_free
    hg_cycle, _, _ = _bent_fibre_block(3.0 * eps_y, then=0.0)
    assert abs(hg_cycle) < 1e-6 * hg_plastic  # the bend's cycle closes: no hourglass work left, none created
