"""3D solid SPH (solver.sph3d): kernel, neighbour search, the stress update, conservation, walls,
conversion of failed hexahedra, and the verification cases at small sizes."""

import math

import numba
import numpy as np
import pytest

from solver.sph import materials as mt
from solver.sph3d import loop, particles as pp, walls as wl
from solver.sph3d.kernel import gradw_factor3, w_and_factor3, w_cubic3

E, NU, RHO = 2.96e9, 0.4, 1280.0


def _block(n=6, dp=1e-3, v=None, **prm):
    x = pp.lattice3((0, 0, 0), (n * dp, n * dp, n * dp), dp)
    mats = mt.table(mt.isotropic(E, NU, RHO))
    return pp.from_points(x, mats, pp.make_params(dp, **prm), v=v(x) if v is not None else None)


def test_kernel_integrates_to_one_and_its_factor_is_its_derivative():
    h, dp = 1.3, 0.1
    g = np.arange(-30, 31) * dp
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    r = np.sqrt(X**2 + Y**2 + Z**2).ravel()
    total = sum(w_cubic3(float(ri), h) for ri in r[r < 2 * h]) * dp**3
    assert abs(total - 1.0) < 1e-3
    for ri in (0.05, 0.4, 0.99, 1.01, 1.7, 1.99):
        w, f = w_and_factor3(ri, h)
        assert w == pytest.approx(w_cubic3(ri, h), rel=1e-12, abs=1e-15)
        assert f == pytest.approx(gradw_factor3(ri, h), rel=1e-12)
        d = 1e-6
        assert f * ri == pytest.approx((w_cubic3(ri + d, h) - w_cubic3(ri - d, h)) / (2 * d), rel=1e-5)


def test_cell_list_finds_exactly_the_brute_force_pairs():
    from solver.sph3d.cells import brute_neighbours3, cell_neighbours3

    rng = np.random.default_rng(3)
    x = rng.uniform(0, 1, (3, 700)) * np.array([[3.0], [1.0], [0.5]])
    x[:, :50] += 20.0  # a detached cloud far away
    assert sorted(cell_neighbours3(x, 0.2)) == sorted(brute_neighbours3(x, 0.2))


def test_principal_values_and_the_spectral_map_match_numpy():
    from solver.sph3d.solid import spectral_map3, sym_eig3

    rng = np.random.default_rng(0)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    for lam in ([3.0, -1.0, 0.5], [2.0, 2.0, -1.0], [1.0, -4.0, -4.0], [5.0, 5.0, 5.0]):
        S = Q @ np.diag(lam) @ Q.T
        v = (S[0, 0], S[1, 1], S[2, 2], S[0, 1], S[1, 2], S[0, 2])
        e = sym_eig3(*v)
        assert np.allclose(e, sorted(lam, reverse=True), atol=1e-7)
        t = [-0.3 * max(x, 0.0) for x in e]  # the artificial stress's map
        out = spectral_map3(*v, *e, *t)
        ref = Q @ np.diag([-0.3 * max(x, 0.0) for x in lam]) @ Q.T
        assert np.allclose(out, (ref[0, 0], ref[1, 1], ref[2, 2], ref[0, 1], ref[1, 2], ref[0, 2]), atol=1e-6)


def test_jaumann_update_rotates_the_stress_of_a_spinning_particle():
    """A pure spin L = Omega (no strain) turns the stress with the body: sigma(t) = R sigma0 R^T."""
    from solver.sph3d.solid import update_state

    mats = mt.table(mt.isotropic(E, NU, RHO))
    s0 = np.array([[3.0, 1.0, 0.5], [1.0, -2.0, 0.2], [0.5, 0.2, 1.0]]) * 1e6
    w = 2.0  # rad/s about z: v = w (-y, x, 0), L = [[0, -w, 0], [w, 0, 0], [0, 0, 0]]
    L = np.array([0, -w, 0, w, 0, 0, 0, 0, 0], float).reshape(9, 1)
    sig = np.array([[s0[0, 0]], [s0[1, 1]], [s0[2, 2]], [s0[0, 1]], [s0[1, 2]], [s0[0, 2]]])
    rho, cs, est, m = np.array([RHO]), np.zeros(1), np.zeros(1), np.array([1.0])
    R6 = np.zeros((6, 1))
    n, t = 4000, 0.5
    for _ in range(n):
        update_state(L, rho, sig, np.zeros((6, 1)), np.zeros((2, 1)), R6, cs, est, m, np.zeros(1, np.int32), mats,
                     0.0, t / n)
    c, s = math.cos(w * t), math.sin(w * t)
    Rm = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    ref = Rm @ s0 @ Rm.T
    got = np.array([[sig[0, 0], sig[3, 0], sig[5, 0]], [sig[3, 0], sig[1, 0], sig[4, 0]], [sig[5, 0], sig[4, 0], sig[2, 0]]])
    assert np.abs(got - ref).max() < 2e-3 * np.abs(s0).max()
    assert abs(est[0]) < 1e-12  # a rigid spin does no work


def test_corrected_gradient_of_a_linear_velocity_field_is_exact_up_to_the_surface():
    G = np.array([[0.3, -1.0, 0.2], [0.5, 0.1, -0.4], [0.0, 0.7, -0.2]]) * 100.0
    P = _block(6, v=lambda x: G @ x)
    loop.prime(P)
    corrected = np.abs(P.B - np.eye(3).reshape(9, 1)).max(axis=0) > 1e-12
    assert corrected.mean() > 0.9  # all but a few corners
    err = np.abs(P.L[:, corrected] - G.reshape(9, 1)).max()
    assert err < 1e-8 * np.abs(G).max()
    assert np.allclose(P.rmin, 1e-3)


def test_momentum_is_conserved_and_the_result_does_not_depend_on_the_thread_count():
    rng = np.random.default_rng(1)
    runs = []
    for th in (1, 2):
        if th > numba.config.NUMBA_NUM_THREADS:
            pytest.skip("needs two numba threads")
        P = _block(9, v=lambda x: rng.normal(0, 2.0, x.shape) if th == 1 else runs[0][2])
        v0 = P.v.copy()
        p0 = P.momentum()
        old = numba.get_num_threads()
        numba.set_num_threads(th)
        try:
            P.forces_valid = False
            loop.prime(P)
            args = loop._args(P)  # past step_chunk's one-thread rule for small problems
            status, done, *_ = loop.advance(*args, 30, 0.5 * loop.stable_dt(P))
        finally:
            numba.set_num_threads(old)
        assert status == loop.OK and done == 30
        scale = float(np.sum(P.m) * np.abs(v0).max())
        assert np.abs(P.momentum() - p0).max() < 1e-13 * scale
        runs.append((P.x.copy(), P.v.copy(), v0))
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])


def test_a_shearing_block_keeps_its_total_energy():
    L = 8e-3
    P = _block(8, dp=1e-3, v=lambda x: np.vstack([2.0 * np.sin(2 * np.pi * x[1] / L), 0 * x[0], 0 * x[0]]))
    e0 = P.energies()["total"]
    hist, rep = loop.run(P, 4e-6, sample=lambda Q: {"e": Q.energies()["total"], "ke": Q.energies()["kinetic"]})
    t, v = hist.arrays()
    assert rep.status == "ok"
    assert v["ke"].min() < 0.8 * e0  # energy did move into the stress
    assert np.abs(v["e"] - e0).max() < 5e-3 * e0


def test_a_block_bounces_off_a_frictionless_floor_and_keeps_its_tangential_momentum():
    dp = 1e-3
    P = _block(5, dp=dp, v=lambda x: np.vstack([np.full(x.shape[1], 3.0), np.full(x.shape[1], -5.0), np.zeros(x.shape[1])]))
    P.x[1] += 0.6 * dp  # the lowest layer 1.1 dp above the floor y = 0
    dt = 0.3 * P.h / (P.cs.max() + 6.0)
    P.walls = wl.strip_walls(5 * dp, wl.wall_stiffness_for(dt, 0.5), floor_y=0.0)
    P.walls[:2, 2] += np.array([-1.0, 1.0]) * dp  # lateral planes clear of the block
    px0 = P.momentum()[0]
    e0 = P.energies()["total"]
    hist, rep = loop.run(P, 1.2e-3, sample=lambda Q: {"e": Q.energies()["total"],
                                                      "pen": wl.penalty_energy(Q.x, Q.m, Q.walls),
                                                      "ww": Q.energies()["walls_work"]})
    assert rep.status == "ok"
    vy = float(np.sum(P.m * P.v[1]) / P.m.sum())
    assert vy > 2.0  # rebounded (some energy left in vibration and viscosity)
    assert abs(P.momentum()[0] - px0) < 1e-12 * abs(px0)  # frictionless: no tangential force
    t, v = hist.arrays()
    # kinetic + stress work + dissipated - the walls' work (which is minus the penalty energy they hold)
    assert np.abs(v["e"] - e0).max() < 0.01 * e0
    assert v["pen"].max() > 0.01 * e0 and np.abs(v["ww"] + v["pen"]).max() < 0.01 * e0
    assert P.x[1].min() > -0.5 * dp


def test_the_strip_walls_push_only_penetrating_particles_along_their_normals():
    from solver.sph3d.walls import wall_accel

    W = wl.strip_walls(2.0, 100.0, floor_y=0.0)
    assert wall_accel(0.5, 0.5, 1.0, W) == (0.0, 0.0, 0.0)
    assert wall_accel(0.5, 0.5, -0.1, W) == pytest.approx((0.0, 0.0, 10.0))
    assert wall_accel(0.5, -0.2, 2.3, W) == pytest.approx((0.0, 20.0, -30.0))


def _hex_state(n=(4, 3, 2), a=1e-5, seed=2):
    from solver.fem3d import gridmesh3d, loop as floop, material3d

    mesh = gridmesh3d.box_mesh(*n, n[0] * a, n[1] * a, n[2] * a, perturb=0.1, seed=seed)
    return floop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(E, NU)], [RHO])


def test_conversion_conserves_mass_and_momentum_and_books_the_kinetic_energy_lost():
    from solver.sph3d import conversion as cv

    s = _hex_state()
    rng = np.random.default_rng(4)
    s.v[:] = rng.normal(0.0, 1.0, s.v.shape)
    conv = cv.start(s, mt.table(mt.isotropic(E, NU, RHO)), pp.make_params(1e-5))
    m0 = s.mass.sum()
    p0 = (s.mass * s.v).sum(axis=1)
    ke0 = 0.5 * np.sum(s.mass * s.v**2)
    cmass0 = s.cmass.copy()
    new = conv.convert(s, [3, 1, 3, 10])
    assert new.tolist() == [0, 1, 2] and conv.convert(s, [1]).size == 0  # an element converts once
    P = conv.particles
    assert abs(s.mass.sum() + P.m.sum() - m0) <= 1e-15 * m0
    assert np.abs((s.mass * s.v).sum(axis=1) + P.momentum() - p0).max() < 1e-15 * m0 * np.abs(s.v).max()
    ke1 = 0.5 * np.sum(s.mass * s.v**2) + P.energies()["kinetic"]
    assert conv.e_conversion > 0 and ke0 - ke1 == pytest.approx(conv.e_conversion, rel=1e-9)
    assert np.array_equal(s.meff, s.mass)
    # the tool's penalty is k per unit mass on the contact mass: a node that gave up mass must not keep the
    # old mass there (omega dt = sqrt(k cmass / meff) dt would grow past the tool's own sqrt(k) dt)
    touched = np.unique(s.hexes[[1, 3, 10]])
    assert (s.cmass[touched] < cmass0[touched]).all()
    assert np.array_equal(s.cmass, s.meff)


def test_a_converted_element_carries_its_cauchy_stress_and_current_density():
    from solver.sph3d import conversion as cv

    s = _hex_state(seed=5)
    Fg = np.array([[1.02, 0.03, 0.0], [0.01, 0.97, 0.02], [0.0, -0.02, 1.01]])
    s.x[:] = Fg @ s.X0
    S = np.array([[2.0, 0.3, -0.1], [0.3, -1.0, 0.4], [-0.1, 0.4, 0.5]]) * 1e7
    s.pk2[:] = [S[0, 0], S[1, 1], S[2, 2], S[0, 1], S[1, 2], S[0, 2]]
    conv = cv.start(s, mt.table(mt.isotropic(E, NU, RHO)), pp.make_params(1e-5))
    conv.convert(s, [7])
    J = np.linalg.det(Fg)
    sig = Fg @ S @ Fg.T / J
    P = conv.particles
    assert np.allclose(P.sig[:, 0], [sig[0, 0], sig[1, 1], sig[2, 2], sig[0, 1], sig[1, 2], sig[0, 2]], rtol=1e-10, atol=1e-3)
    assert P.rho[0] == pytest.approx(RHO / J, rel=1e-10)
    assert np.allclose(P.x[:, 0], s.x[:, s.hexes[7]].mean(axis=1))


def test_verification_cases_at_small_size():
    from solver.verification.sph3d_cases import run_bar3, run_conversion3, run_spheres

    c_sph, c, det = run_bar3(n_long=24, n_cross=3)
    assert det["status"] == "ok" and abs(c_sph - c) / c < 0.03
    drift, det, _ = run_spheres(n_radius=4)
    assert det["status"] == "ok" and det["u_left_final_over_u0"] < 0 and det["components_per_sphere"] == [1, 1]
    assert drift < 0.01 and abs(det["momentum_x_final_over_sphere_momentum"]) < 1e-12
    dm, dpm, det = run_conversion3(n=(4, 3, 2), n_steps=30)
    assert det["status"] == "ok" and det["converted"] > 0 and max(dm, dpm) < 1e-12


def test_bench_rows_from_the_cli(capsys):
    import json

    from cli.main import main

    assert main(["bench", "sph", "--dim", "3", "--threads", "1", "--sizes", "300,700", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["dim"] for r in rows] == [3, 3] and all(r["status"] == "ok" and r["updates_per_s"] > 0 for r in rows)
    assert rows[0]["loglog_slope"] is None and rows[1]["loglog_slope"] > 0


def _stretch3(mats, L, t_end, n, sig=None, eps_as=0.3):
    """One 3D particle under the constant velocity gradient L (3x3) for t_end in n steps: its state."""
    from solver.sph3d.solid import update_state

    st = {"L": np.asarray(L, float).reshape(9, 1).copy(), "rho": np.array([mats[0, mt.M_RHO0]]),
          "sig": np.zeros((6, 1)) if sig is None else sig, "sst": np.zeros((6, 1)), "dmg": np.zeros((2, 1)),
          "R": np.zeros((6, 1)), "cs": np.zeros(1), "est": np.zeros(1), "m": np.array([1e-15])}
    return _more3(st, mats, t_end, n, eps_as)


def _more3(st, mats, t_end, n, eps_as=0.3, L=None):
    from solver.sph3d.solid import update_state

    if L is not None:
        st["L"] = np.asarray(L, float).reshape(9, 1).copy()
    for _ in range(n):
        update_state(st["L"], st["rho"], st["sig"], st["sst"], st["dmg"], st["R"], st["cs"], st["est"], st["m"],
                     np.zeros(1, np.int32), mats, eps_as, t_end / n)
    return st


@pytest.mark.parametrize("L2", [[[10.0, 0.0], [0.0, 0.0]], [[10.0, 4.0], [-1.0, -3.0]]])
def test_tensile_damage_is_the_2d_law_in_plane_strain(L2):
    """The 3D particles' tensile damage is the 2D engine's law (solver.sph.solid): under a plane-strain
    velocity gradient whose largest principal stress lies in the plane, the damage, the acting in-plane
    stress and the stress work agree with the 2D kernel's to round-off, through d = 1."""
    from solver.sph import particles as pp2, solid as solid2

    row = mt.isotropic(2.96e9, 0.4, 1280.0, D0=0.1, kappa_f=0.02)
    mats = mt.table(row)
    P = pp2.from_points([0.0], [0.0], mats, pp2.make_params(1e-6, eps=0.3))
    F = P.F
    F[pp2.LXX], F[pp2.LXY], F[pp2.LYX], F[pp2.LYY] = L2[0][0], L2[0][1], L2[1][0], L2[1][1]
    L3 = [[L2[0][0], L2[0][1], 0.0], [L2[1][0], L2[1][1], 0.0], [0.0, 0.0, 0.0]]
    st = None
    seen = []
    for _ in range(16):  # blocks of 0.15 ms (0.15 % strain at 10/s), to beyond kappa_f = 2 %
        for _ in range(50):
            solid2.update_state(P.F, P.I, P.act, P.n_act, P.mats, P.prm, 3e-6)
        st = _stretch3(mats, L3, 1.5e-4, 50) if st is None else _more3(st, mats, 1.5e-4, 50)
        d2, d3 = F[pp2.DMG, 0], st["dmg"][1, 0]
        seen.append(d3)
        assert d3 == pytest.approx(d2, rel=1e-9, abs=1e-12)
        s3 = st["sig"][:, 0]
        scale = abs(F[pp2.SXX, 0]) + abs(F[pp2.SYY, 0]) + 1.0
        for a, b in ((s3[0], F[pp2.ESXX, 0]), (s3[1], F[pp2.ESYY, 0]), (s3[3], F[pp2.ESXY, 0])):
            assert a == pytest.approx(b, abs=1e-7 * scale)
        # the out-of-plane stress (not in 2D) keeps the work per unit volume close: the work is the 2D one
        # plus sigma_zz eps_zz = 0 (eps_zz = 0)
        assert st["est"][0] * st["rho"][0] / 1e-15 == pytest.approx(F[pp2.EST, 0] * F[pp2.RHO, 0] / F[pp2.M, 0],
                                                                    rel=1e-6)
    assert 0.0 < min(s for s in seen if s > 0) < 1.0 and seen[-1] == 1.0  # grew through partial to full


def test_tensile_damage_makes_a_powder_grain_that_carries_compression_and_does_not_dilate():
    """Pulled past kappa_f a particle becomes powder: no tension in any direction (the state clipped to
    its compressive part), its density floored at rho0 while it is pulled further, no artificial
    stress; pushed back, it carries compression with the (1 - D0) stiffness. Compression alone grows no
    damage."""
    D0, kf, rho0 = 0.1, 0.02, 1280.0
    row = mt.isotropic(2.96e9, 0.4, rho0, D0=D0, kappa_f=kf)
    mats = mt.table(row)
    squeeze = _stretch3(mats, np.diag([-10.0, -5.0, 0.0]), 2e-3, 100)
    assert squeeze["dmg"][1, 0] == 0.0 and squeeze["sig"][0, 0] < 0
    # triaxial pull: the largest principal strain rate is 10/s, kappa_f reached at 2 ms
    st = _stretch3(mats, np.diag([10.0, 6.0, 3.0]), 1e-3, 100)
    assert 0.4 < st["dmg"][1, 0] < 0.6
    assert st["R"][0, 0] < 0  # the artificial stress opposes the tension
    st = _more3(st, mats, 2e-3, 200)
    assert st["dmg"][1, 0] == 1.0
    assert st["sig"][:3, 0].max() <= 0.0 and np.all(st["R"][:, 0] == 0.0)
    assert st["rho"][0] == rho0  # floored, against rho0 exp(-19 x 3 ms)
    st = _more3(st, mats, 1e-3, 100, L=np.diag([-10.0, 0.0, 0.0]))  # compaction by 1 %
    assert st["rho"][0] > rho0
    assert st["sig"][0, 0] < -0.5 * (1 - D0) * row[mt.M_C11] * 0.01
    assert st["dmg"][1, 0] == 1.0
