"""The 3D cohesive interface element (solver.fem3d.cohesive3d): the law on one element, its forces'
balance and invariance, and the verification cases at small size."""

import math

import numpy as np
import pytest

from solver.fem3d import cohesive3d as c3

K, N, S, GIC, GIIC, ETA = 1e14, 60e6, 80e6, 300.0, 900.0, 1.45
CP = c3.cohesive_props(K, N, S, GIC, GIIC, ETA)
H = 1e-3  # element side: area 1e-6 m^2


def _element(quad=None):
    """One element: a-nodes 0-3 (a square in the plane z = 0), b-nodes 4-7 at the same places; side B above."""
    if quad is None:
        quad = np.array([[0, 0, 0], [H, 0, 0], [H, H, 0], [0, H, 0]], float)
    X = np.hstack([quad.T, quad.T])
    coh = np.array([[0, 1, 2, 3, 4, 5, 6, 7]], np.int32)
    return X, coh, np.array([0.5 * np.linalg.norm(np.cross(quad[2] - quad[0], quad[3] - quad[1]))]), np.array([1.0])


def _arrays():
    return np.zeros((1, 4)), np.zeros((1, 4, c3.N_CH)), np.zeros(1), np.zeros(1), np.zeros(1, np.int8), np.zeros((1, 24))


def _run_path(direction, dmax, n=4000):
    """Open the b-face by s * direction (s = 0 .. dmax) in n increments; returns (openings, tractions, work, diss, state)."""
    X, coh, area, sign = _element()
    dmg, ch, cw, cd, cst, fc = _arrays()
    x = X.copy()
    dt = 1.0
    u = np.asarray(direction, float)
    ops, tr = [], []
    for i in range(1, n + 1):
        s = dmax * i / n
        xn = X.copy()
        xn[:, 4:] += s * u[:, None]
        v = (xn - x) / dt
        x = xn
        c3.cohesive3d_update(0, coh, sign, area, CP, dmg, ch, cw, cd, cst, x, v, dt, fc)
        fb = fc[0, 12:].reshape(4, 3).sum(axis=0)  # force on side B
        ops.append(s)
        tr.append(-fb @ u / area[0])
    return np.array(ops), np.array(tr), cw[0] / area[0], cd[0] / area[0], (dmg, ch, cst)


def test_mode_one_peak_and_energy():
    dmax = 2.2 * 2 * GIC / N
    s, t, work, diss, (dmg, _, cst) = _run_path([0, 0, 1], dmax)
    assert abs(t.max() - N) / N < 0.01
    assert abs(diss - GIC) / GIC < 0.01
    assert abs(work - GIC) / GIC < 0.01
    assert np.all(dmg == 1.0) and cst[0] == c3.DEBONDED


@pytest.mark.parametrize("direction", [[1, 0, 0], [0, 1, 0], [math.sqrt(0.5), -math.sqrt(0.5), 0]])
def test_mode_two_any_tangential_direction(direction):
    dmax = 2.2 * 2 * GIIC / S
    s, t, work, diss, (dmg, _, cst) = _run_path(direction, dmax)
    assert abs(t.max() - S) / S < 0.01
    assert abs(diss - GIIC) / GIIC < 0.01
    assert abs(work - GIIC) / GIIC < 0.01
    assert cst[0] == c3.DEBONDED


def test_mixed_mode_bk():
    # proportional path at 45 deg between n and a tangent: B = 1/2
    u = np.array([0.0, 1.0, 1.0]) / math.sqrt(2)
    gc = GIC + (GIIC - GIC) * 0.5 ** ETA
    d0n, d0s = N / K, S / K
    d0m = d0n * d0s * math.sqrt(2 / (d0s ** 2 + d0n ** 2))
    dfm = 2 * gc / (K * d0m)
    s, t, work, diss, (dmg, _, cst) = _run_path(u, 1.1 * dfm)
    assert abs(t.max() - K * d0m) / (K * d0m) < 0.01
    assert abs(diss - gc) / gc < 0.01
    assert abs(work - gc) / gc < 0.01


def _rot(axis, ang):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    Km = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(ang) * Km + (1 - math.cos(ang)) * Km @ Km


def test_rigid_motion_of_a_closed_element_gives_no_force():
    X, coh, area, sign = _element()
    dmg, ch, cw, cd, cst, fc = _arrays()
    dmg[:] = 0.4
    x = _rot([1, 2, 3], 0.7) @ X + np.array([[1e-3], [-2e-3], [5e-4]])
    c3.cohesive3d_update(0, coh, sign, area, CP, dmg, ch, cw, cd, cst, x, np.zeros_like(x), 1.0, fc)
    assert np.abs(fc).max() < 1e-12 * K * H ** 3


@pytest.mark.parametrize("turn_deg", [100.0, 150.0, 179.9])
def test_an_element_whose_faces_turned_apart_debonds_and_exerts_no_force(turn_deg):
    """The B face turned about an axis in its plane by 90 degrees or more against the A face: the mid-surface
    degenerates as the faces cross, so the element debonds at once: damage 1 at every point, no force, its free
    energy at that opening booked as dissipation, w [(1/2)(1 - d) K (<dn>^2 + ds^2) + (1/2) K <-dn>^2] per point."""
    X, coh, area, sign = _element()
    dmg, ch, cw, cd, cst, fc = _arrays()
    dmg[:] = 0.4
    x = X.copy()
    centre = np.array([[0.5 * H], [0.5 * H], [0.0]])
    x[:, 4:] = _rot([1, 0, 0], math.radians(turn_deg)) @ (X[:, 4:] - centre) + centre
    mode = c3.cohesive3d_update(0, coh, sign, area, CP, dmg, ch, cw, cd, cst, x, np.zeros_like(x), 1.0, fc)
    assert mode == 10 and cst[0] == c3.DEBONDED and np.all(dmg == 1.0)
    assert np.all(fc == 0.0)
    dn, ds = ch[0, :, c3.H_DN], ch[0, :, c3.H_DS]
    psi = 0.25 * area[0] * 0.5 * K * (0.6 * (np.maximum(dn, 0) ** 2 + ds ** 2) + np.minimum(dn, 0) ** 2)
    assert cd[0] == pytest.approx(psi.sum(), rel=1e-12) and cd[0] > 0
    dmg, ch, cw, cd, cst, fc = _arrays()  # turned by 60 degrees: the law decides
    dmg[:] = 0.4
    x[:, 4:] = _rot([1, 0, 0], math.radians(60.0)) @ (X[:, 4:] - centre) + centre
    c3.cohesive3d_update(0, coh, sign, area, CP, dmg, ch, cw, cd, cst, x, np.zeros_like(x), 1.0, fc)
    assert np.abs(fc).max() > 0 and np.isfinite(fc).all()


def test_forces_balance_and_are_the_free_energy_gradient():
    rng = np.random.default_rng(4)
    quad = np.array([[0, 0, 0], [H, 0.1 * H, 0], [1.1 * H, 0.9 * H, 0.05 * H], [-0.1 * H, H, 0]], float)
    X, coh, area, sign = _element(quad)
    x0 = _rot([0.3, -1, 0.5], 0.4) @ X + rng.uniform(-0.3, 0.3, X.shape) * N / K
    x0[2, 4:6] -= N / K  # two points closed (below the onset: damage held)
    for d in (0.0, 0.3, 0.8):
        dmg, ch, cw, cd, cst, fc = _arrays()
        dmg[:] = d
        c3.cohesive3d_update(0, coh, sign, area, CP, dmg, ch, cw, cd, cst, x0, np.zeros_like(x0), 1.0, fc)
        assert np.all(dmg == d)  # below the onset
        assert 0 < (ch[0, :, c3.H_DN] < 0).sum() < 4  # open and closed points
        f = fc[0].reshape(8, 3).T
        scale = np.abs(f).max()
        assert scale > 0
        assert np.abs(f.sum(axis=1)).max() < 1e-9 * scale
        mom = np.cross(x0.T, f.T).sum(axis=0)
        assert np.abs(mom).max() < 1e-9 * scale * H
        # f = -d psi / dx (central differences, damage held)
        eps = 1e-4 * N / K
        for node in (0, 2, 5, 7):
            for i in range(3):
                e = []
                for sgn in (1, -1):
                    xp = x0.copy()
                    xp[i, node] += sgn * eps
                    dm2, ch2, cw2, cd2, cs2, fc2 = _arrays()
                    dm2[:] = d
                    c3.cohesive3d_update(0, coh, sign, area, CP, dm2, ch2, cw2, cd2, cs2, xp, np.zeros_like(xp), 1.0, fc2)
                    e.append(c3.cohesive3d_free_energy(0, area, CP, dm2, ch2))
                fd = -(e[0] - e[1]) / (2 * eps)
                assert abs(fd - f[i, node]) < 1e-5 * scale


def test_geometry_sign_and_area():
    from solver.fem3d import gridmesh3d
    m = gridmesh3d.split_box_mesh(2, 1, 1, 1, 2e-3, 1e-3, 1e-3, 1e-3, bonded=(0.0, 2e-3))
    area, sign = c3.cohesive3d_geometry(m.X, m.cohesive, m.hexes)
    assert np.allclose(area, 1e-6)
    n = c3.tangents(m.X, m.cohesive, sign)[:, 0]
    assert np.allclose(n, [0, 0, 1])


# ----------------------------------------------------------------------------- in the engine
from solver.verification import load_cases  # noqa: E402

CASES = load_cases()


def run(name, **overrides):
    res = CASES[name][0](overrides)
    assert res.wall_time_s >= 0
    return res


def test_cohesive_cases_registered():
    for name in ("fem3d-dcb", "fem3d-enf", "fem3d-bridge"):
        assert name in CASES


def test_split_mesh_without_cohesive_is_two_free_blocks_and_stable_step_includes_the_interface():
    from solver.fem3d import gridmesh3d, loop, material3d
    m = gridmesh3d.split_box_mesh(4, 1, 1, 1, 4e-3, 1e-3, 1e-3, 1e-3, bonded=(2e-3, 4e-3))
    assert m.n_cohesive == 2 and m.n_elems == 8 and m.n_nodes == 2 * 5 * 2 * 2
    s = loop.build_state(m.X, m.hexes, [material3d.isotropic_stiffness(1e9, 0.3)], [1000.0])
    dt0 = loop.stable_dt(s)
    loop.add_cohesive(s, m.cohesive, c3.cohesive_props(1e16, 1e6, 1e6, 100.0, 100.0, 1.45))
    assert loop.stable_dt(s) < dt0  # a penalty this stiff limits the step
    assert np.all(s.csign == 1.0)  # the lower block is side A


def test_dcb_peak_softening_and_energy_balance():
    """Mode I at 0.67 mm elements (the 2D test's size), 8 arm periods: corrected beam theory's peak (5 %)."""
    res = run("fem3d-dcb", nx=90, periods=8)
    assert res.error < 0.05, res.details
    assert res.details["softening_mean_error"] < 0.10, res.details
    assert res.details["debonded"] > 0
    assert res.details["energy_error"] < 1e-3, res.details


def test_bridge_elastic_strip_is_the_plane_strain_engine():
    res = run("fem3d-bridge", nx=10, nz=2, dcb=0)
    assert res.value < 1e-8, res.details


def test_bridge_dcb_peak_matches_the_2d_engine():
    from solver.verification import fem_cases
    from solver.verification.fem3d_cases import dcb3d
    r2 = fem_cases.case_dcb({"nx": 40, "periods": 3.0})
    loads = dcb3d(40, 2, periods=3.0)[1]
    assert abs(loads.max() - r2.value) / r2.value < 0.02


def test_enf_critical_load_in_mode_ii():
    """End-notched flexure at 1 mm elements (the 2D test's size): beam theory's critical load (5 %), the
    crack grows and the load drops after the peak (unstable growth from a0 = L/2)."""
    res = run("fem3d-enf", nx=100, periods=8)
    assert res.error < 0.05, res.details
    assert res.details["debonded_grown"] > 0 and res.details["load_drop_after_peak"] > 0.2, res.details
    assert res.details["energy_error"] < 1e-3, res.details


def test_cohesive_loop_is_thread_independent_and_balances_energy():
    """A split bar (2 across the width, so the cohesive elements are genuinely 3D) opened at one end until
    some elements debond: the same steps with one and with two threads give the same state, and the energy
    balance closes."""
    from solver.fem3d import gridmesh3d, loop, material3d

    def make():
        m = gridmesh3d.split_box_mesh(30, 2, 2, 2, 0.03, 2e-3, 1.5e-3, 1.5e-3, bonded=(0.01, 0.03))
        s = loop.build_state(m.X, m.hexes, [material3d.isotropic_stiffness(70e9, 0.3)], [2700.0])
        loop.add_cohesive(s, m.cohesive, c3.cohesive_props(1e13, 20e6, 20e6, 300.0, 600.0, 1.45))
        left = m.X[0] < 1e-12
        up = np.arange(m.n_nodes) >= m.n_lower
        s.fix[2, left] = 1
        s.vp[2, left & up] = 2.0
        s.vp[2, left & ~up] = -2.0
        s.fix[:, m.X[0] > 0.03 - 1e-12] = 1
        s.damping = 1000.0
        return s

    import copy

    a = make()
    assert loop.advance(a, 7000, threads=1).status == "ok"
    b = copy.deepcopy(a)  # the last steps, while elements debond, with one and with two threads
    assert loop.advance(a, 600, threads=1).status == "ok"
    assert loop.advance(b, 600, threads=2).status == "ok"
    assert np.array_equal(a.x, b.x) and np.array_equal(a.dmg, b.dmg) and np.array_equal(a.cwork, b.cwork)
    assert (a.cstate > 0).sum() > 0 and np.any((a.dmg > 0) & (a.dmg < 1))
    e = loop.energies(a)
    assert e["energy_error"] < 1e-3, e
    assert e["cohesive_dissipated"] > 0 and abs(e["cohesive_unaccounted"]) < 0.01 * e["external"], e
