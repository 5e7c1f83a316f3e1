"""Solid SPH (solver.sph.solid, solver.sph.loop): constitutive update on prescribed velocity
gradients, and the verification cases at test size (solver.verification.sph_cases)."""

import math

import numpy as np

import pytest

from solver.sph import materials as mt, particles as pp, solid
from solver.verification import sph_cases as sc


def _one(mats, theta=0.0, eps=0.0):
    P = pp.from_points([0.0], [0.0], mats, pp.make_params(1e-6, eps=eps), theta=theta)
    return P


def _advance(P, L, t_end, n=2000):
    F = P.F
    F[pp.LXX], F[pp.LXY], F[pp.LYX], F[pp.LYY] = L[0][0], L[0][1], L[1][0], L[1][1]
    dt = t_end / n
    for _ in range(n):
        solid.update_state(P.F, P.I, P.act, P.n_act, P.mats, P.prm, dt)


def test_jaumann_rate_rotates_stress_and_material_axis_with_the_body():
    mats = mt.table(mt.isotropic(1e9, 0.3, 1000.0))
    P = _one(mats, theta=0.2)
    s = 5e6
    P.F[pp.SXX] = s
    w = 100.0
    t = 0.01  # rotation by 1 rad
    _advance(P, [[0.0, -w], [w, 0.0]], t)
    a = w * t
    assert P.F[pp.SXX, 0] == pytest.approx(s * math.cos(a) ** 2, rel=2e-3)
    assert P.F[pp.SYY, 0] == pytest.approx(s * math.sin(a) ** 2, rel=2e-3)
    assert P.F[pp.SXY, 0] == pytest.approx(s * math.sin(a) * math.cos(a), rel=2e-3)
    assert P.F[pp.THETA, 0] == pytest.approx(0.2 + a, rel=1e-12)
    assert P.F[pp.EST, 0] == pytest.approx(0.0, abs=1e-9 * s)  # a rotation does no work


@pytest.mark.parametrize("theta, key", [(0.0, mt.M_C11), (math.pi / 2, mt.M_C22)])
def test_fibre_stiffness_follows_the_material_axis_and_damage(theta, key):
    D0 = 0.8
    row = mt.transversely_isotropic(294e9, 14e9, 28e9, 0.2, 0.25, 1800.0, D0=D0)
    P = _one(mt.table(row), theta=theta)
    e = -1e-4  # compressive uniaxial strain (no tensile damage growth)
    _advance(P, [[e / 1e-3, 0.0], [0.0, 0.0]], 1e-3, n=10)
    assert P.F[pp.SXX, 0] == pytest.approx((1 - D0) * row[key] * e, rel=1e-6)
    # plane-strain stiffness from the 3D compliance: C11 above the 1D modulus E1 (Poisson coupling)
    assert row[mt.M_C11] > 294e9 and row[mt.M_C66] == 28e9


def test_tensile_damage_grows_to_powder_that_still_carries_compression():
    row = mt.isotropic(2.96e9, 0.4, 1280.0, D0=0.1, kappa_f=0.02)
    P = _one(mt.table(row), eps=0.3)
    rate = 10.0
    _advance(P, [[rate, 0.0], [0.0, 0.0]], 0.001, n=200)  # 1 % strain: half way
    d_half = P.F[pp.DMG, 0]
    assert 0.4 < d_half < 0.6 and P.F[pp.ESXX, 0] > 0
    assert P.F[pp.ESXX, 0] == pytest.approx((1 - d_half) * P.F[pp.SXX, 0], rel=1e-9)
    assert P.F[pp.RXX, 0] < 0  # artificial stress opposes the tension
    _advance(P, [[rate, 0.0], [0.0, 0.0]], 0.0012, n=200)  # beyond kappa_f: fully fractured
    assert P.F[pp.DMG, 0] == 1.0
    assert max(P.F[pp.ESXX, 0], P.F[pp.ESYY, 0]) <= 0.0  # no tension left
    _advance(P, [[-rate, 0.0], [0.0, 0.0]], 0.001, n=200)  # compaction
    assert P.F[pp.ESXX, 0] < -0.5 * (1 - 0.1) * row[mt.M_C11] * 0.01  # compression with (1 - D0) stiffness


def test_density_stays_positive_and_a_powder_grain_does_not_dilate():
    """Continuity d rho/dt = -rho tr L: exact for a constant expansion rate (rho0 exp(-tr L t)) and
    positive even for tr L dt > 1, where rho + dt d rho/dt would be negative (and the sound speed
    sqrt(C / rho) NaN: the full d08 scene's blow-up). A fully fractured particle (powder grain) moving
    away from its neighbours keeps its solid density; in compaction its density rises."""
    row = mt.isotropic(2.96e9, 0.4, 1280.0, D0=0.8, kappa_f=0.5)
    P = _one(mt.table(row))
    rate = 100.0
    _advance(P, [[rate, 0.0], [0.0, 0.0]], 0.002, n=200)  # 20 % expansion, damage not yet full
    assert P.F[pp.RHO, 0] == pytest.approx(1280.0 * math.exp(-rate * 0.002), rel=1e-12)
    _advance(P, [[rate, 0.0], [0.0, 0.0]], 0.05, n=2)  # tr L dt = 2.5 per step
    assert P.F[pp.DMG, 0] == 1.0
    assert P.F[pp.RHO, 0] == 1280.0 and math.isfinite(P.F[pp.CS, 0])
    _advance(P, [[-rate, 0.0], [0.0, 0.0]], 0.001, n=100)
    assert P.F[pp.RHO, 0] == pytest.approx(1280.0 * math.exp(rate * 0.001), rel=1e-12)
    Q = _one(mt.table(mt.isotropic(2.96e9, 0.4, 1280.0)))  # intact solid: continuity, positive
    _advance(Q, [[rate, 0.0], [0.0, 0.0]], 0.05, n=2)
    assert 0.0 < Q.F[pp.RHO, 0] == pytest.approx(1280.0 * math.exp(-5.0), rel=1e-12)


def _velocity_gradient(P):
    """The corrected velocity gradient L_i of P's current velocities (one pass of the kernel)."""
    from solver.sph import loop
    from solver.sph.cells import NSTEN, build_cells
    from solver.sph.kernel import SUPPORT
    order, cell_of, _ = loop._buffers(P)
    start, ncx, ncy, x0, y0, cell, ok = build_cells(P.F[pp.X], P.F[pp.Y], P.act, P.n_act, SUPPORT * P.h / NSTEN,
                                                    order, cell_of)
    assert ok
    solid.gather_kinematics(P.F, P.S, order, P.n_act)
    solid.velocity_gradient(P.F, P.S, order, P.n_act, start, ncx, ncy, x0, y0, cell, P.h, True)
    return np.array([[P.F[pp.LXX], P.F[pp.LXY]], [P.F[pp.LYX], P.F[pp.LYY]]])


def test_corrected_velocity_gradient_is_exact_and_objective_up_to_the_corners_of_a_body():
    """First-order consistency of the corrected kernel gradient (Randles & Libersky 1996; Bonet & Lok
    1999): a linear velocity field v = v0 + G x has the gradient G at every particle of a compact body,
    its free surfaces and its corners included; in particular a rigid rotation (G antisymmetric) gives
    no strain rate anywhere (objectivity). The corners of a lattice have a quarter neighbourhood
    (det M = 0.14 at h = 1.3 dp); an acceptance test det M > 0.25 left them with the raw gradient
    G M, so that a rotating body strained its corners."""
    dp = 1e-3
    mats = mt.table(mt.isotropic(2e6, 0.3975, 1000.0))
    x, y = pp.lattice(0.0, 12 * dp, 0.0, 6 * dp, dp)
    for G in ([[0.0, -3.0], [3.0, 0.0]], [[0.7, -2.1], [1.3, -0.4]]):
        G = np.array(G)
        P = pp.from_points(x, y, mats, pp.make_params(dp), vx=0.2 + G[0, 0] * x + G[0, 1] * y,
                           vy=-0.1 + G[1, 0] * x + G[1, 1] * y)
        L = _velocity_gradient(P)
        assert np.allclose(L, G[:, :, None], rtol=0, atol=1e-9 * np.abs(G).max())
        strain_rate = np.hypot(L[0, 0] - G[0, 0], L[1, 1] - G[1, 1])
        assert strain_rate.max() < 1e-9 * np.abs(G).max()


@pytest.mark.parametrize("material", ["isotropic", "fibre"])
def test_wave_speed_in_a_bar(material):
    c_sph, c, det = sc.run_bar(n_long=25, material=material)
    assert det["status"] == "ok"
    assert abs(c_sph - c) / c < 0.03


def test_artificial_stress_softens_tension_by_a_few_percent():
    """Documented side effect (Gray et al. 2001's remedy): without compressive prestress the bar
    oscillates through tension, where eps = 0.3 lowers the measured speed by a few percent."""
    c0, c, _ = sc.run_bar(n_long=25, prestress=0.0, eps=0.0)
    c3, _, _ = sc.run_bar(n_long=25, prestress=0.0, eps=0.3)
    assert abs(c0 - c) / c < 0.03
    assert 0.005 < (c0 - c3) / c < 0.06


def test_colliding_rings_rebound_without_fracture_clumping_or_energy_drift():
    drift, det, _ = sc.run_rings(n_thick=5)
    assert det["status"] == "ok", det["finding"]
    assert det["u_left_final_over_u0"] < -0.3  # the rings bounced back apart
    assert det["components_per_ring"] == [1, 1]  # no fracture
    assert det["min_distance_over_dp"] > 0.5  # no clumping
    assert drift < 0.01


def test_oscillating_plate_frequency_converges_towards_thin_plate_theory():
    """With the quadratic-complete gradient in the outermost row (the case's default) the plate is
    -8.2 % (6 particles through the thickness), -6.5 % (8), -5.6 % (10), -5.0 % (12), -4.7 % (14),
    -4.6 % (16) off thin-plate theory; the first-order gradient everywhere gave -15.9 % / -11.0 % at
    n = 6 / 8 (docs/validation.md). At test size: a first bending mode below theory whose error falls
    with resolution, the quadratic surface row clearly better than the first-order form, with the
    plate intact (no clumping)."""
    w6, om, d6 = sc.run_plate(n_thick=6)
    w8, _, d8 = sc.run_plate(n_thick=8)
    w8f, _, d8f = sc.run_plate(n_thick=8, quadratic=0.0)
    assert d6["status"] == d8["status"] == d8f["status"] == "ok"
    e6, e8, e8f = (w6 - om) / om, (w8 - om) / om, (w8f - om) / om
    assert -0.10 < e6 < e8 < 0.0
    assert e8f < e8 - 0.03  # first-order: -11.0 % vs -6.5 %
    assert min(d6["min_distance_over_dp"], d8["min_distance_over_dp"]) > 0.7


def test_oscillating_plate_within_5_percent_of_thin_plate_theory():
    """The 5 % acceptance, at the cheapest resolution that meets it: 14 particles through the thickness
    (-4.68 % over a full period; n = 12 is at -5.03 %). Run to T/2: twice the first zero crossing of
    the tip gives the period of the full run to 0.04 %."""
    w, om, d = sc.run_plate(n_thick=14, periods=0.5)
    assert d["status"] == "ok" and len(d["crossings_s"]) == 1
    err = (w - om) / om
    assert -0.05 < err < 0.0, err
    assert d["min_distance_over_dp"] > 0.7


def test_tool_pushes_particles():
    """The rigid tool (solver.contact.tool_contact inside the SPH loop) ploughs into a particle block:
    the force on the tool resists its -x motion (Fc > 0), it does positive work on the particles and
    pushes them in -x."""
    from solver.scene import load_scene
    from solver.sph import loop
    from solver.tool import tool_array

    si = load_scene("seed-0deg-hybrid-d08-quick").si()
    dp = 2e-6
    x, y = pp.lattice(0.0, 60e-6, -40e-6, 0.0, dp)
    mats = mt.table(mt.isotropic(2.96e9, 0.4, 1280.0, D0=0.8))
    P = pp.from_points(x, y, mats, pp.make_params(dp), fixed=np.where(x < 6e-6, 3, 0))
    tool = tool_array(si)
    tool[2] = -20.0
    tool[1] = -20e-6 + tool[4]  # cut plane 20 um below the top
    tool[0] = 60e-6 + tool[4] - 1e-6  # already 1 um into the block
    free = P.I[pp.FIXED] == 0
    dt = loop.stable_dt(P)
    tout = np.zeros(4)
    k_pen = 0.1 * float(P.F[pp.M].min()) / dt**2  # the scene's rule (solver.contact.contact_stiffness)
    rep = loop.step_chunk(P, 300, dt, tool=tool, k_pen=k_pen, mu=0.3, tool_out=tout)
    assert rep.status == "ok"
    assert tout[0] > 0  # the workpiece resists the tool's -x motion
    assert rep.tool_work > 0  # the tool does work on the particles it pushes
    px = float(np.sum(P.F[pp.M, free] * P.F[pp.VX, free]))
    assert px < 0  # pushed in -x (the clamped particles at x < 6 um take the rest as the support)


def test_particles_feel_the_tool_penalty_per_unit_mass_at_a_step_that_resolves_it():
    """The hybrid's tool penalty on a particle is k m_p (per unit mass, as on the nodes), and the
    particles' step is held to 1 / sqrt(k) (loop.stable_dt): a light and a 100 times heavier particle
    of a nearly stress-free material (D = 0.99, whose signal-speed step at rest is 10 times that) thrown up
    into the tool's arc sink equally deep, v / sqrt(k) like a spring's amplitude, and bounce back
    at their impact speed (energy conserved in the tool's frame). At the signal-speed step alone
    (omega dt > 2) the same bounce throws the particle off at many times its speed."""
    from solver.contact import contact_stiffness
    from solver.scene import load_scene
    from solver.sph import loop
    from solver.tool import tool_array

    si = load_scene("seed-0deg-hybrid-d08-quick").si()
    tool0 = tool_array(si)
    k_mass = contact_stiffness(1.0, 1e-10)  # 0.1 / dt^2 of an engine step of 0.1 ns
    mats = mt.table(mt.isotropic(2.96e9, 0.4, 1280.0, D0=0.99))
    v_in = 100.0

    def bounce(mass_factor, dt=None):
        P = pp.from_points(np.array([tool0[0]]), np.array([tool0[1] - tool0[4] - 1e-8]), mats, pp.make_params(2e-6))
        P.F[pp.M] *= mass_factor
        P.F[pp.VX] = tool0[2]  # moving with the tool along x, up into the arc's lowest point
        P.F[pp.VY] = v_in
        tool = tool0.copy()
        dt_used = loop.stable_dt(P, k_mass) if dt is None else dt
        depth = 0.0
        for _ in range(int(4e-9 / dt_used) + 1):  # 4 ns: about 6 contact periods' time
            tout = np.zeros(4)
            rep = loop.step_chunk(P, 1, dt_used, tool=tool, k_pen=k_mass, tool_out=tout, tool_by_mass=True)
            depth = max(depth, tout[2])
            if rep.status != "ok":
                return depth, float(P.F[pp.VY, 0]), dt_used, rep
        return depth, float(P.F[pp.VY, 0]), dt_used, rep

    d1, v1, dt1, r1 = bounce(1.0)
    d2, v2, dt2, r2 = bounce(100.0)
    assert r1.status == "ok" and r2.status == "ok"
    signal = loop.stable_dt(pp.from_points(np.zeros(1), np.zeros(1), mats, pp.make_params(2e-6)))
    assert dt1 == pytest.approx(loop.CONTACT_OMEGA_DT / math.sqrt(k_mass)) and signal > 5 * dt1  # the limit acts
    assert d2 == pytest.approx(d1, rel=1e-9) and dt2 == dt1  # per unit mass: same depth, same step
    assert d1 == pytest.approx(v_in / math.sqrt(k_mass), rel=0.15)
    assert v1 == pytest.approx(-v_in, rel=0.05) and v2 == pytest.approx(-v_in, rel=0.05)
    _, v3, _, r3 = bounce(1.0, dt=signal)  # omega dt = sqrt(k) x signal step > 2
    assert math.sqrt(k_mass) * signal > 2.0
    assert r3.status == "unstable" or abs(v3) > 1.5 * v_in  # thrown off (the guard stops it) or gained energy


def test_a_particle_blow_up_ends_unstable_naming_the_particle_where_and_how_fast():
    """A particle kicked to 50 x the sound speed makes the signal-speed step collapse within the chunk:
    the chunk stops unstable and its finding names the particle, its position and its speed."""
    from solver.sph import loop

    dp = 1e-6
    mats = mt.table(mt.isotropic(3e9, 0.3, 1200.0))
    prm = pp.make_params(dp)
    x, y = pp.lattice(0.0, 10 * dp, 0.0, 10 * dp, dp)
    P = pp.from_points(x, y, mats, prm)
    dt = loop.stable_dt(P)
    c = float(P.F[pp.CS, P.active_indices()].max())
    i = int(P.active_indices()[37])
    P.F[pp.VX, i] = 50.0 * c
    rep = loop.step_chunk(P, 64, dt)
    assert rep.status == "unstable" and "signal-speed" in rep.finding
    import re

    named = int(re.search(r"worst particle (\d+)", rep.finding).group(1))
    a = P.active_indices()
    speed = np.hypot(P.F[pp.VX, a], P.F[pp.VY, a])
    assert named == int(a[np.argmin(P.h / (P.F[pp.CS, a] + speed))])  # the one that sets the collapsed step
    assert speed.max() > 10 * c and "m/s" in rep.finding and " um" in rep.finding


def test_the_booked_viscous_dissipation_is_the_kinetic_energy_the_viscosity_takes():
    """Two blocks of a material with next to no stiffness (E = 1 uPa: only Monaghan's viscosity acts)
    run into each other at 20 m/s. The kinetic energy lost must reappear as booked viscous dissipation
    to round-off: every half-kick books the viscous force's work, -m a_v . (v + v') dt / 4, which is
    exactly its share of m (v'^2 - v^2) / 2. (The pair power Pi_ij v_ij . grad W at the half-step
    velocity, the booking of an earlier version, overstated it by 9 % here: in an impact the velocity falls
    within the step.)"""
    from solver.sph import loop

    dp = 2e-6
    xa, ya = pp.lattice(0.0, 20e-6, 0.0, 20e-6, dp)
    xb, yb = pp.lattice(22e-6, 42e-6, 4e-6, 24e-6, dp)
    x, y = np.concatenate([xa, xb]), np.concatenate([ya, yb])
    vx = np.where(x < 21e-6, 10.0, -10.0)
    P = pp.from_points(x, y, mt.table(mt.isotropic(1e-6, 0.3, 1280.0)), pp.make_params(dp, eps=0.0), vx=vx)
    e0 = P.energies()
    for _ in range(6):  # chunks of varying step, as the hybrid's particles take them
        rep = loop.step_chunk(P, 150, loop.stable_dt(P))
        assert rep.status == "ok"
    e1 = P.energies()
    assert e0["kinetic"] - e1["kinetic"] > 0.05 * e0["kinetic"]  # the impact took a real part of it
    assert abs(e1["internal"]) < 1e-9 * e0["kinetic"]  # the stress does next to nothing
    assert e1["viscous"] > 0.0
    assert abs(e1["total"] - e0["total"]) < 1e-10 * e0["kinetic"]


def test_the_booked_tool_work_is_the_kinetic_energy_the_tool_gives_also_when_the_step_changes():
    """A block of a material with next to no stiffness (E = 1 uPa) ploughed by the tool, in chunks
    whose step changes from one to the next as the hybrid's particle sub-chunks do: the kinetic
    energy gained plus the viscous dissipation must equal the tool's booked work to round-off. Each
    half-kick books its force's work, m a . (v + v') dt / 4 (solver.sph.loop._kick_one); the
    end-of-step power F^{n+1} . v^{n+1} dt (an earlier booking) is exact only where the two
    half-kicks around t^{n+1} have the same step: here it missed by 1.6 %."""
    from solver.scene import load_scene
    from solver.sph import loop
    from solver.tool import tool_array

    si = load_scene("seed-0deg-hybrid-d08-quick").si()
    dp = 2e-6
    x, y = pp.lattice(0.0, 30e-6, -30e-6, 0.0, dp)
    P = pp.from_points(x, y, mt.table(mt.isotropic(1e-6, 0.3, 1280.0)), pp.make_params(dp, eps=0.0))
    tool = tool_array(si)
    tool[2] = -20.0
    tool[1] = -20e-6 + tool[4]  # cut plane 20 um below the top
    tool[0] = 30e-6 + tool[4] - 1e-6  # already 1 um into the block
    k_mass = 1e20  # per unit mass [1/s^2]: omega = 1e10 rad/s, the step held to 0.1 ns
    e0 = P.energies()
    work = 0.0
    for factor in (1.0, 0.6, 0.9, 0.5, 1.0, 0.7) * 40:  # chunks of 4 steps: contacts span their ends
        dt = factor * loop.stable_dt(P, k_mass)
        rep = loop.step_chunk(P, 4, dt, tool=tool, k_pen=k_mass, mu=0.3, tool_by_mass=True)
        assert rep.status == "ok"
        work += rep.tool_work
    e1 = P.energies()
    assert work > 0.0 and e1["kinetic"] > 0.1 * work  # the tool pushed the block along
    assert abs(e1["internal"]) < 1e-9 * work
    assert abs((e1["total"] - e0["total"]) - work) < 1e-9 * work


def _press(dt, travel=3e-6, dp=2.5e-6, n=16):
    """A square block of fibre particles (the hybrid's fibre particle: E1 = 294 GPa, 1 - D0 = 0.9), its two
    left columns held as a wall, pressed by the flat rake face of the quick scenes' tool made sharp at rake 0
    (their tool speed), with the hybrid's tool penalty per unit mass (omega dt = 1). Returns the tool's
    work and what the particles hold (kinetic + stress work + viscous + artificial stress) [J/m]."""
    from solver.scene import load_scene
    from solver.sph import loop
    from solver.tool import tool_array

    mats = mt.table(mt.transversely_isotropic(294e9, 14e9, 9e9, 0.3, 0.4, 1800.0, D0=0.1))
    x, y = pp.lattice(0.0, n * dp, -n * dp, 0.0, dp)
    P = pp.from_points(x, y, mats, pp.make_params(dp), fixed=np.where(x < 2 * dp, 3, 0))
    si = load_scene("seed-0deg-hybrid-d01-quick", {"tool.rake_angle_deg": 0, "tool.edge_radius_um": 0}).si()
    tool = tool_array(si, x_start=n * dp + 0.5 * dp)  # rake face at x = tool[0]
    tool[1] = -(n + 4) * dp  # its tip below the block
    steps = int(travel / -tool[2] / dt)
    work = 0.0
    for _ in range(steps // 500):
        rep = loop.step_chunk(P, 500, dt, tool=tool, k_pen=1.0 / dt**2, tool_by_mass=True, threads=1)
        assert rep.status == "ok"
        work += rep.tool_work
    e = P.energies()
    return work, e["kinetic"] + e["internal"] + e["viscous"] + e["artificial_stress"]


def test_particles_pressed_by_the_tool_hold_the_work_it_did_and_the_balance_converges_with_the_step():
    """Energy: the tool's work on the particles (booked in the kicks) against what they hold, the stress
    work booked from the constitutive update: the two sides of the SPH momentum and stress-power pair. At
    the hybrid's step for fibre particles (0.1 ns) the block, pressed 3 um (7 % strain), holds the work to
    2e-5, and the residual falls at least by 1.6 as the step halves (first order: the stress of step n
    books its work over the step with the mid-step rate). Under an extreme press (15 um, particles
    squeezed to a fraction of dp and squirting out) the balance breaks down (4 % created at 0.025 ns; at
    0.05 ns the step collapses, docs/numerics.md)."""
    w1, h1 = _press(1e-10)
    w2, h2 = _press(5e-11)
    r1, r2 = abs(h1 - w1) / w1, abs(h2 - w2) / w2
    assert w1 > 0.0 and w2 > 0.0
    assert r1 < 1e-4
    assert r2 < r1 / 1.6
