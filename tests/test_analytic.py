"""The analytic fidelity (solver/analytic.py): trends a machinist knows, closed-form limits,
continuity in fibre angle, finiteness over the whole valid input space, speed, and that an
analytic run imports no numba. No test compares against a number the model printed."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from solver import load_scene, run
from solver.analytic import analytic_forces, ply_properties, run_analytic

CONTRACT = ("cutting_force_N_per_mm", "thrust_force_N_per_mm", "damage_depth_um", "bounce_back_um", "energy_error")


def scene(**overrides):
    """The paper's 0-degree scene as an analytic run with a tall workpiece (depths up to 1 mm)."""
    ov = {"fidelity": "analytic", "workpiece.height_um": 5000.0}
    ov.update({k.replace("__", "."): v for k, v in overrides.items()})
    return load_scene("seed-0deg-fem", ov)


def metrics(**overrides) -> dict:
    return run_analytic(scene(**overrides)).metrics


def fc(**kw):
    return metrics(**kw)["cutting_force_N_per_mm"]


def ft(**kw):
    return metrics(**kw)["thrust_force_N_per_mm"]


ANGLES = (0.0, 30.0, 60.0, 90.0, 120.0, 150.0)
RAKES = (-45.0, -10.0, 0.0, 10.0, 30.0, 60.0)
DEPTHS = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0)


# ----------------------------------------------------------------------------- contract
def test_analytic_run_returns_the_contract_summary():
    result = run(scene())
    assert result.status == "ok" and result.steps == 0
    summary = result.summary()
    for key in CONTRACT:
        assert isinstance(summary[key], float) and math.isfinite(summary[key]), key
    assert summary["energy_error"] == 0.0
    m = result.metrics
    for part in ("cutting", "thrust"):  # the regional breakdown adds up to the total
        total = sum(m[f"{region}_{part}_force_N_per_mm"] for region in ("chipping", "pressing", "bouncing"))
        assert total == pytest.approx(m[f"{part}_force_N_per_mm"], rel=1e-12)


def test_analytic_run_imports_no_numba():
    code = textwrap.dedent("""
        import sys
        import solver, solver.analytic
        from solver import load_scene, run
        r = run(load_scene("seed-90deg-fem", {"fidelity": "analytic"}))
        assert r.status == "ok", r.summary()
        bad = sorted(m for m in sys.modules if m.startswith("numba"))
        assert not bad, bad
        print("ok")
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_the_benchmark_times_a_call_at_each_fibre_angle():
    """The speed itself is measured by ``fibrecut bench analytic`` (docs/scaling.md), not here: a
    timed test fails under load; this checks the benchmark measures the calls."""
    from solver import bench

    rows = bench.get("analytic")(sizes=[3])
    assert [r["fibre_angle_deg"] for r in rows] == [0.0, 45.0, 90.0]
    assert all(r["calls"] == 3 and r["us_per_call"] > 0 and r["calls_per_s"] == pytest.approx(1e6 / r["us_per_call"])
               for r in rows)


# ----------------------------------------------------------------------------- closed-form limits
def test_sharp_isotropic_limit_is_merchants_minimum_energy_solution():
    """Sharp edge, equal shear resistance along and across the fibres: Merchant (1945),
    phi = pi/4 - lambda/2 and F_c = 2 tau t cos(lambda) / (1 - sin(lambda)), F_t = F_c tan(lambda)."""
    tau_f = 594.5 / math.sqrt(3.0)  # fibre shear yield from the compressive yield (von Mises)
    for rake, mu in ((0.0, 0.3), (30.0, 0.3), (-20.0, 0.6), (10.0, 0.0)):
        s = scene(tool__edge_radius_um=0.0, tool__rake_angle_deg=rake, tool__friction=mu,
                  materials__interface__shear_strength_MPa=tau_f, materials__matrix__sigma_u_MPa=1000.0,
                  workpiece__fibre_angle_deg=0.0, cut__depth_um=100.0)
        m = analytic_forces(s.si())
        lam = math.atan(mu) - math.radians(rake)
        expected = 2.0 * tau_f * 1e6 * 100e-6 * math.cos(lam) / (1.0 - math.sin(lam))
        assert m["Fc"] == pytest.approx(expected, rel=5e-3)
        assert m["Ft"] == pytest.approx(expected * math.tan(lam), rel=5e-3, abs=1e-6 * expected)
        assert math.degrees(m["chip"]["phi"]) == pytest.approx(45.0 - math.degrees(lam) / 2.0, abs=1.5)


def test_pressing_forces_are_the_integral_of_the_arc_tractions():
    from scipy.integrate import quad

    m = analytic_forces(scene(workpiece__fibre_angle_deg=60.0, tool__edge_radius_um=30.0).si())
    p, r, mu, psi = m["press"]["pressure"], 30e-6, 0.3, m["psi_p"]
    fx = quad(lambda q: p * r * (math.sin(q) + mu * math.cos(q)), 0.0, psi)[0]
    fy = quad(lambda q: p * r * (math.cos(q) - mu * math.sin(q)), 0.0, psi)[0]
    assert m["press"]["Fc"] == pytest.approx(fx, rel=1e-10) and m["press"]["Ft"] == pytest.approx(fy, rel=1e-10)


@pytest.mark.parametrize("vf", [0.3, 0.5, 0.7])
def test_ply_properties_follow_the_rule_of_mixtures(vf):
    """E1 is the fibre and matrix strips side by side (equal strain: the forces add), E2 the strips
    in series (equal stress: the elongations add), each from a unit load on a unit-width stack."""
    si = scene(workpiece__fibre_volume_fraction=vf).si()
    ply = ply_properties(si)
    ef1, ef2, em = si.fibre.E1, si.fibre.E2, si.matrix.E
    strain = 1e-3  # along the fibres: both strips stretched equally, widths vf and 1 - vf
    assert ply.E1 * strain == pytest.approx(ef1 * strain * vf + em * strain * (1.0 - vf), rel=1e-12)
    stress = 1e6  # across: both strips carry the stress, thicknesses vf and 1 - vf
    assert stress / ply.E2 == pytest.approx(stress / ef2 * vf + stress / em * (1.0 - vf), rel=1e-12)
    assert em < ply.E2 < ef2 and ply.E2 < ply.E1 < ef1  # series below parallel, both between the phases


def test_sharp_tool_has_no_pressing_or_bouncing_region():
    m = metrics(tool__edge_radius_um=0.0)
    for key in ("pressing_cutting_force_N_per_mm", "pressing_thrust_force_N_per_mm",
                "bouncing_cutting_force_N_per_mm", "bouncing_thrust_force_N_per_mm", "bounce_back_um"):
        assert m[key] == 0.0, key
    assert m["cutting_force_N_per_mm"] > 0.0


# ----------------------------------------------------------------------------- machinist's trends
@pytest.mark.parametrize("theta", ANGLES)
def test_cutting_force_grows_with_depth(theta):
    for rake in RAKES:
        for r in (0.0, 5.0, 20.0):
            forces = [fc(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=rake, tool__edge_radius_um=r,
                         cut__depth_um=a) for a in DEPTHS if r <= 10 * a]
            assert all(b > a for a, b in zip(forces, forces[1:])), (rake, r, forces)


@pytest.mark.parametrize("theta", ANGLES)
def test_thrust_grows_with_depth_when_rake_is_below_the_friction_angle(theta):
    """Merchant: the chip's thrust is F_c tan(beta - alpha), so it adds to the thrust when
    the rake angle is below the friction angle (a large positive rake pulls the tool in)."""
    for rake, mu in ((-10.0, 0.3), (0.0, 0.3), (10.0, 0.3), (10.0, 1.0)):
        forces = [ft(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=rake, tool__friction=mu, cut__depth_um=a)
                  for a in DEPTHS if a >= 2.0]
        assert all(b > a for a, b in zip(forces, forces[1:])), (rake, mu, forces)


@pytest.mark.parametrize("theta", ANGLES)
def test_thrust_grows_with_edge_radius(theta):
    for rake in (0.0, 10.0, 30.0, 60.0):
        for a in (20.0, 100.0, 1000.0):
            forces = [ft(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=rake, cut__depth_um=a,
                         tool__edge_radius_um=r) for r in (0.0, 1.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0)]
            assert all(b > a_ for a_, b in zip(forces, forces[1:])), (rake, a, forces)


def test_cutting_force_at_90_degrees_is_above_0_degrees():
    for rake in RAKES:
        for r in (0.0, 5.0, 20.0, 100.0):
            for mu in (0.1, 0.3, 1.0):
                for a in DEPTHS:
                    if r > 10 * a:
                        continue
                    kw = dict(tool__rake_angle_deg=rake, tool__edge_radius_um=r, tool__friction=mu, cut__depth_um=a)
                    assert fc(workpiece__fibre_angle_deg=90.0, **kw) > fc(workpiece__fibre_angle_deg=0.0, **kw), kw


@pytest.mark.parametrize("theta", ANGLES)
def test_larger_rake_lowers_cutting_force(theta):
    for mu in (0.1, 0.3, 1.0, 2.0):
        for r, a in ((0.0, 100.0), (20.0, 100.0), (20.0, 20.0), (100.0, 1000.0)):
            forces = [fc(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=rake, tool__friction=mu,
                         tool__edge_radius_um=r, cut__depth_um=a) for rake in (-45, -30, -10, 0, 10, 20, 30, 45, 60)]
            assert all(b < a_ for a_, b in zip(forces, forces[1:])), (mu, r, a, forces)


@pytest.mark.parametrize("theta", ANGLES)
def test_friction_raises_cutting_force(theta):
    for rake in RAKES:
        for r, a in ((0.0, 100.0), (20.0, 100.0), (20.0, 10.0)):
            forces = [fc(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=rake, tool__edge_radius_um=r,
                         cut__depth_um=a, tool__friction=mu) for mu in (0.0, 0.1, 0.3, 0.6, 1.0, 2.0)]
            assert all(b > a_ for a_, b in zip(forces, forces[1:])), (rake, r, a, forces)


def test_friction_raises_thrust_for_the_papers_tools():
    for theta in ANGLES:
        for rake in (10.0, 30.0):
            forces = [ft(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=rake, tool__friction=mu)
                      for mu in (0.3, 0.6, 1.0, 2.0)]
            assert all(b > a for a, b in zip(forces, forces[1:])), (theta, rake, forces)


def test_bounce_back_is_of_the_order_of_the_edge_radius():
    for theta in ANGLES:
        for r in (5.0, 20.0, 50.0):
            b = metrics(workpiece__fibre_angle_deg=theta, tool__edge_radius_um=r)["bounce_back_um"]
            assert 0.1 * r < b < r, (theta, r, b)


def test_damage_depth_grows_with_depth_of_cut_and_falls_with_interface_strength():
    """The stress field scales with the tool force, the damaged radius inversely with the strengths."""
    for theta in (0.0, 45.0, 90.0, 135.0):
        d = [metrics(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=10.0, cut__depth_um=a)["damage_depth_um"]
             for a in (20.0, 50.0, 100.0, 300.0)]
        assert all(b > a for a, b in zip(d, d[1:])), (theta, d)
        weak = metrics(workpiece__fibre_angle_deg=theta, materials__interface__shear_strength_MPa=12.5,
                       materials__interface__normal_strength_MPa=50.0, materials__matrix__sigma_u_MPa=40.0)
        strong = metrics(workpiece__fibre_angle_deg=theta)
        assert weak["damage_depth_um"] > strong["damage_depth_um"] > 0.0


# ----------------------------------------------------------------------------- continuity in fibre angle
@pytest.mark.parametrize("overrides", [{}, {"tool.edge_radius_um": 0.0},
                                       {"tool.rake_angle_deg": -45.0, "tool.friction": 2.0},
                                       {"tool.rake_angle_deg": 60.0, "tool.clearance_angle_deg": 0.0, "cut.depth_um": 5.0}])
def test_forces_are_continuous_in_fibre_angle(overrides):
    """Small angle steps give small force steps (no jump anywhere in 0-180, including 90), and
    the largest step shrinks with the step size: the functions are Lipschitz, not just sampled."""
    si = load_scene("seed-0deg-fem", {"fidelity": "analytic", "workpiece.height_um": 5000.0, **overrides}).si()

    def f(deg):
        si.fibre_angle = math.radians(deg)
        m = analytic_forces(si)
        return m["Fc"], m["Ft"], m["damage_depth"], m["bounce"]["bounce_back"]

    def worst_step(step):
        worst = [0.0] * 4
        for i in range(0, 1801):
            a, b = f(i * 0.1), f(i * 0.1 + step)
            worst = [max(w, abs(x - y)) for w, x, y in zip(worst, a, b)]
        return worst

    scale = [max(abs(v) for v in col) for col in zip(*(f(i * 0.5) for i in range(361)))]
    coarse, fine = worst_step(0.01), worst_step(0.001)
    for w, wf, s in zip(coarse, fine, scale):
        assert w <= 2e-3 * s + 1e-12  # 0.01 deg moves nothing by more than 0.2 % of its range
        assert wf <= 0.2 * w + 1e-12  # a ten times smaller step gives a (about) ten times smaller change


def test_0_and_180_degrees_are_the_same_orientation():
    a, b = metrics(workpiece__fibre_angle_deg=0.0), metrics(workpiece__fibre_angle_deg=180.0)
    for key in CONTRACT:
        assert a[key] == pytest.approx(b[key], rel=1e-9, abs=1e-12), key
    near0, near180 = metrics(workpiece__fibre_angle_deg=0.1), metrics(workpiece__fibre_angle_deg=179.9)
    for key in CONTRACT:  # 0.1 and 179.9 are 0.2 deg apart: as close as 0.1 is to 0 and 179.9 to 180
        gap = abs(near0[key] - near180[key])
        assert gap <= 1e-2 * abs(a[key]) + 1e-9, key
        assert gap <= 2.5 * max(abs(near0[key] - a[key]), abs(near180[key] - b[key])) + 1e-9, key


# ----------------------------------------------------------------------------- finite everywhere
@st.composite
def valid_overrides(draw):
    a = draw(st.floats(1.0, 1000.0))
    rake = draw(st.floats(-45.0, 60.0))
    return {
        "workpiece.fibre_angle_deg": draw(st.floats(0.0, 180.0)),
        "workpiece.fibre_volume_fraction": draw(st.floats(0.05, 0.85)),
        "cut.depth_um": a,
        "tool.rake_angle_deg": rake,
        "tool.clearance_angle_deg": draw(st.floats(0.0, min(30.0, 84.9 - rake))),
        "tool.edge_radius_um": draw(st.floats(0.0, min(200.0, 10.0 * a))),
        "tool.friction": draw(st.floats(0.0, 2.0)),
        "materials.fibre.E1_GPa": draw(st.floats(1.0, 1000.0)),
        "materials.fibre.E2_GPa": draw(st.floats(0.1, 1000.0)),
        "materials.fibre.G12_GPa": draw(st.floats(0.1, 1000.0)),
        "materials.fibre.nu12": draw(st.floats(0.0, 0.49)),
        "materials.fibre.Xc_GPa": 50.0,
        "materials.fibre.compressive_yield_MPa": draw(st.floats(1.0, 50000.0)),
        "materials.matrix.E_GPa": draw(st.floats(0.01, 1000.0)),
        "materials.matrix.nu": draw(st.floats(0.0, 0.499)),
        "materials.matrix.sigma_u_MPa": draw(st.floats(0.1, 10000.0)),
        "materials.interface.normal_strength_MPa": draw(st.floats(0.1, 10000.0)),
        "materials.interface.shear_strength_MPa": draw(st.floats(0.1, 10000.0)),
    }


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(valid_overrides())
def test_every_valid_scene_gives_finite_values(overrides):
    s = load_scene("seed-0deg-fem", {"fidelity": "analytic", "workpiece.height_um": 5000.0, **overrides})
    result = run_analytic(s)
    assert result.status == "ok"
    for key, value in result.metrics.items():
        assert math.isfinite(value), (key, value)
    m = result.metrics
    # (the cutting force itself may be negative: with little friction and no chip, the spring-back
    # against an inclined clearance face pushes the tool forward)
    assert m["damage_depth_um"] >= 0.0 and m["bounce_back_um"] >= 0.0 and m["pressed_thickness_um"] >= 0.0


def test_extreme_corners_give_finite_values():
    for theta in (0.0, 90.0, 180.0):
        for rake, clearance in ((-45.0, 0.0), (-45.0, 30.0), (60.0, 0.0), (60.0, 24.9)):
            for a, r in ((1.0, 0.0), (1.0, 10.0), (1000.0, 0.0), (1000.0, 200.0), (20.0, 200.0)):
                for mu in (0.0, 2.0):
                    m = metrics(workpiece__fibre_angle_deg=theta, tool__rake_angle_deg=rake,
                                tool__clearance_angle_deg=clearance, cut__depth_um=a, tool__edge_radius_um=r,
                                tool__friction=mu)
                    assert all(math.isfinite(v) for v in m.values()), m


# ----------------------------------------------------------------------------- the damage stress field
def test_damage_stress_field_is_compatible_in_the_orthotropic_ply():
    """sigma_r = E(v) (A cos v + B sin v) / rho (the radial distribution used for the damage
    depth) must satisfy strain compatibility with the ply's rotated compliance; the isotropic
    Flamant field (E constant) must not, which shows the check has teeth."""
    import numpy as np

    from solver.analytic import offaxis_modulus

    ply = ply_properties(scene().si())
    theta, a_c, b_c = math.radians(35.0), 2.0, 3.0
    s_loc = np.array([[1 / ply.E1, -ply.nu12 / ply.E1, 0], [-ply.nu12 / ply.E1, 1 / ply.E2, 0], [0, 0, 1 / ply.G12]])
    c, s = math.cos(theta), math.sin(theta)
    t = np.array([[c * c, s * s, 2 * c * s], [s * s, c * c, -2 * c * s], [-c * s, c * s, c * c - s * s]])
    r = np.diag([1.0, 1.0, 2.0])
    s_glob = r @ np.linalg.inv(t) @ np.linalg.inv(r) @ s_loc @ t  # engineering strains, global axes

    def strain(x, y, anisotropic):
        rho = math.hypot(x, y)
        cx, sy = x / rho, y / rho
        n = np.array([cx * cx, sy * sy, cx * sy])
        # direction (cx, sy) makes the angle atan2(sy, cx) - theta with the fibres
        e = offaxis_modulus(ply, math.atan2(sy, cx) - theta) if anisotropic else 1.0
        return s_glob @ (e * (a_c * cx + b_c * sy) / rho * n)

    def residual(x, y, anisotropic, h=1e-3):
        f = lambda X, Y: strain(X, Y, anisotropic)  # noqa: E731
        exx_yy = (f(x, y + h)[0] - 2 * f(x, y)[0] + f(x, y - h)[0]) / h**2
        eyy_xx = (f(x + h, y)[1] - 2 * f(x, y)[1] + f(x - h, y)[1]) / h**2
        gxy_xy = (f(x + h, y + h)[2] - f(x + h, y - h)[2] - f(x - h, y + h)[2] + f(x - h, y - h)[2]) / (4 * h * h)
        return abs(exx_yy + eyy_xx - gxy_xy) / (abs(exx_yy) + abs(eyy_xx) + abs(gxy_xy))

    points = ((0.3, -0.7), (1.1, -0.4), (-0.5, -0.9))
    assert max(residual(x, y, True) for x, y in points) < 5e-5  # finite-difference noise only
    assert max(residual(x, y, False) for x, y in points) > 1e-2
