"""The matrix's paraboloid law (solver.fem.paraboloid, solver.fem.materials): return mapping against the
analytic yield points, consistency, the plastic Poisson ratio, the crack band's energy per unit crack length
at any element size, and the patch test of an element with the law."""

import math

import numpy as np
import pytest

from solver.fem.materials import H_EQP, H_EQPT, LAW, LAW_PARABOLOID, N_HIST, material_stress, material_table
from solver.fem.paraboloid import flow_alpha, paraboloid_return, paraboloid_yield
from solver.scene import Scene

E, NU = 2.96e9, 0.4
G, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
#: the default preset's tensile and compressive yields (95 and 594.5 MPa, docs/model.md)
_MATRIX = Scene().materials.matrix
ST, SC = _MATRIX.sigma_u_MPa * 1e6, _MATRIX.compressive_yield_MPa * 1e6


def _props(**matrix):
    scene = Scene.model_validate({"materials": {"matrix": matrix}}) if matrix else Scene()
    return material_table(scene.si())


@pytest.mark.parametrize("direction,expected", [(+1, ST), (-1, SC)])
def test_uniaxial_yield_points(direction, expected):
    """A uniaxial trial stress far outside returns to the uniaxial yield point of its sign."""
    s = paraboloid_return(direction * 5 * expected, 0.0, 0.0, 0.0, 0.0, 0.0, G, K, ST, SC, flow_alpha(0.3))
    # the non-associated return moves the lateral stresses too: the point lands on the surface
    assert abs(paraboloid_yield(*s[:6], ST, SC)) < 1e-8 * 2 * SC * ST
    # a stress path that stays uniaxial meets the surface at exactly the yield stress
    f = paraboloid_yield(direction * expected, 0.0, 0.0, 0.0, 0.0, 0.0, ST, SC)
    assert abs(f) < 1e-9 * 2 * SC * ST


def test_pure_shear_yields_at_the_analytic_stress():
    tau_y = math.sqrt(SC * ST / 3.0)
    assert abs(paraboloid_yield(0, 0, 0, tau_y, 0, 0, ST, SC)) < 1e-9 * SC * ST
    s = paraboloid_return(0.0, 0.0, 0.0, 3 * tau_y, 0.0, 0.0, G, K, ST, SC, flow_alpha(0.3))
    assert s[3] == pytest.approx(tau_y, rel=1e-9)  # no mean stress: the return is radial in the deviator
    assert s[0] == pytest.approx(0.0, abs=1e-6 * tau_y)


@pytest.mark.parametrize("trial", [(300e6, -200e6, 50e6, 120e6), (-900e6, -300e6, -600e6, 700e6),
                                   (90e6, 90e6, 90e6, 0.0), (20e6, 10e6, 0.0, 150e6)])
def test_return_lands_on_the_surface_along_the_flow(trial):
    """Consistency f = 0 after the return, and the plastic strain increment is what the stress lost through
    the elastic law: sigma = sigma_trial - C : d eps_p."""
    sxx, syy, szz, sxy = trial
    assert paraboloid_yield(sxx, syy, szz, sxy, 0.0, 0.0, ST, SC) > 0.0  # the trial lies outside
    nu_p = 0.3
    out = paraboloid_return(sxx, syy, szz, sxy, 0.0, 0.0, G, K, ST, SC, flow_alpha(nu_p))
    assert paraboloid_yield(*out[:6], ST, SC) == pytest.approx(0.0, abs=1e-7 * 2 * SC * ST)
    d = np.array(out[6:12])
    lam = K - 2 * G / 3
    tr = d[0] + d[1] + d[2]
    lost = np.array([lam * tr + 2 * G * d[0], lam * tr + 2 * G * d[1], lam * tr + 2 * G * d[2], 2 * G * d[3]])
    assert np.allclose(np.array([sxx, syy, szz, sxy]) - lost, np.array(out[:4]), rtol=0, atol=1e-6 * SC)
    assert out[12] > 0.0


def test_plastic_poisson_ratio():
    """In uniaxial stress the plastic flow contracts laterally by nu_p (the flow potential's alpha)."""
    for nu_p in (0.0, 0.3, 0.45):
        a = flow_alpha(nu_p)
        sig = ST  # on the surface in uniaxial tension; the flow direction there
        p = sig / 3
        n = np.array([3 * (sig - p) + 2 * a * p / 3, 3 * (-p) + 2 * a * p / 3])
        assert -n[1] / n[0] == pytest.approx(nu_p, rel=1e-12, abs=1e-12)


def test_inside_the_surface_is_elastic():
    out = paraboloid_return(10e6, -20e6, 5e6, 30e6, 0.0, 0.0, G, K, ST, SC, flow_alpha(0.3))
    assert out[:4] == (10e6, -20e6, 5e6, 30e6) and out[12] == 0.0


def _pull(props, l_c, e_max, n=4000):
    """Uniaxial plane strain Exx from 0 to e_max on one point of size l_c; returns (work per volume, stresses, hist)."""
    hist = np.zeros((1, N_HIST))
    w, s_prev, e_prev, out = 0.0, 0.0, 0.0, []
    for exx in np.linspace(0.0, e_max, n):
        sxx = material_stress(props, 1, 1.0, 0.0, exx, 0.0, 0.0, 0.0, hist, 0, l_c * l_c, True)[0]
        w += 0.5 * (sxx + s_prev) * (exx - e_prev)
        s_prev, e_prev = sxx, exx
        out.append(sxx)
    return w, np.array(out), hist


@pytest.mark.parametrize("l_c", [1e-6, 2.5e-6, 5e-6])
def test_crack_band_opens_fully(l_c):
    """A matrix point pulled open in plane strain softens to zero stress, never above the tensile yield,
    with all its flow under a tensile mean stress."""
    props = _props(fracture_energy_N_mm=0.277)
    assert props[1, LAW] == LAW_PARABOLOID
    w, s, hist = _pull(props, l_c, e_max=3.0 * 2 * 277.0 / ST / l_c)
    assert s[-1] == pytest.approx(0.0, abs=1e-9)
    assert s.max() <= ST * 1.0001
    assert hist[0, H_EQPT] == pytest.approx(hist[0, H_EQP])


def test_crack_band_energy_is_size_independent():
    """The energy per unit crack length is the same at 1, 2.5 and 5 um (to 2 %): the crack band's purpose
    (the brittle law's falls in proportion to the element size)."""
    props = _props(fracture_energy_N_mm=0.277)
    w = [_pull(props, l_c, 3 * 2 * 277 / ST / l_c)[0] * l_c for l_c in (1e-6, 2.5e-6, 5e-6)]
    assert max(w) / min(w) - 1 < 0.02


def test_crack_band_dissipates_fracture_energy_in_uniaxial_stress():
    """In uniaxial stress (lateral stresses zero, the 3D return mapping with the lateral strains solved for)
    the work to full damage per unit crack length l_c W is G_c (linear softening in the equivalent plastic
    strain, which in uniaxial stress is the axial plastic strain), to within the elastic energy at the peak."""
    from solver.fem.paraboloid import equivalent_plastic_increment

    gc, l_c, nu_p = 277.0, 2e-6, 0.3
    uf = 2 * gc / ST
    lam, a = K - 2 * G / 3, flow_alpha(nu_p)
    ep = np.zeros(3)  # plastic strain xx, yy = zz
    eqp, w, s_prev, e_prev = 0.0, 0.0, 0.0, 0.0
    for exx in np.linspace(0.0, 1.5 * uf / l_c, 3000):
        def trial(elat):
            ex, ey = exx - ep[0], elat - ep[1]
            tr = ex + 2 * ey
            return paraboloid_return(lam * tr + 2 * G * ex, lam * tr + 2 * G * ey, lam * tr + 2 * G * ey, 0, 0, 0,
                                     G, K, ST, SC, a)
        lo, hi = -exx - 1e-3, 0.0
        for _ in range(60):  # the lateral strain with zero lateral stress
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if trial(mid)[1] < 0 else (lo, mid)
        out = trial(0.5 * (lo + hi))
        ep += np.array([out[6], out[7], out[7]])
        eqp += equivalent_plastic_increment(*out[6:12], nu_p)
        sxx = (1 - min(1.0, l_c * eqp / uf)) * out[0]
        w += 0.5 * (sxx + s_prev) * (exx - e_prev)
        s_prev, e_prev = sxx, exx
    assert s_prev == pytest.approx(0.0, abs=1e-6)
    assert w * l_c == pytest.approx(gc + ST ** 2 / (2 * E) * l_c, rel=0.02)


def test_compression_flows_without_damage():
    """Compressed along x and bulging along y (a slightly compressive mean stress), the matrix yields on the
    surface and flows with no crack opening; squeezed in uniaxial strain (nearly hydrostatic) it does not yield."""
    props = _props()
    hist = np.zeros((1, N_HIST))
    for exx in np.linspace(0.0, -0.3, 600):
        out = material_stress(props, 1, 1.0, 0.0, exx, -0.9 * exx, 0.0, 0.0, hist, 0, 4e-12, True)
    assert hist[0, H_EQP] > 0.1 and hist[0, H_EQPT] == 0.0
    assert out[5] == 0  # not failed (eq. plastic strain below eps_f = 0.5)
    assert paraboloid_yield(out[0], out[1], out[3], out[2], 0.0, 0.0, ST, SC) == pytest.approx(0.0, abs=1e-6 * SC * ST)
    hist[:] = 0.0
    for exx in np.linspace(0.0, -0.1, 200):
        material_stress(props, 1, 1.0, 0.0, exx, 0.0, 0.0, 0.0, hist, 0, 4e-12, True)
    assert hist[0, H_EQP] == 0.0  # the paraboloid is open towards hydrostatic compression


def test_ductile_failure_at_the_failure_strain():
    props = _props(failure_plastic_strain=0.05)
    hist = np.zeros((1, N_HIST))
    mode = 0
    for g in np.linspace(0.0, 0.5, 2000):  # simple shear
        mode = material_stress(props, 1, 1.0, 0.0, 0.0, 0.0, 0.5 * g, 0.0, hist, 0, 4e-12, True)[5]
        if mode:
            break
    assert mode == 12 and hist[0, H_EQP] == pytest.approx(0.05, rel=0.02)


def test_bad_matrix_settings_are_named():
    from solver.scene import SceneError, scene_from_dict

    with pytest.raises(SceneError, match="materials.matrix.compressive_yield_MPa"):
        scene_from_dict({"materials": {"matrix": {"compressive_yield_MPa": 50}}})
    with pytest.raises(SceneError, match="materials.matrix.fracture_energy_N_mm"):
        scene_from_dict({"materials": {"matrix": {"fracture_energy_N_mm": None}}})


def test_patch_of_distorted_elements_under_plastic_flow_keeps_one_stress():
    """Patch test with the paraboloid law past yield: an affine motion (with a 35-deg rigid rotation) applied in
    increments gives every distorted element the same stress and plastic history, equal to the law driven along
    the same strain path, and no force on the interior node."""
    from solver import fem
    from solver.fem.state import P_EMAX
    from solver.mesh import Mesh

    X = np.array([0.0, 1.0, 2.0, 0.0, 1.15, 2.0, 0.0, 0.9, 2.0]) * 1e-5
    Y = np.array([0.0, 0.0, 0.0, 1.0, 0.85, 1.0, 2.0, 2.0, 2.0]) * 1e-5
    quads = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]], np.int32)
    mesh = Mesh(x=X, y=Y, quads=quads, material=np.ones(4, np.int8), fibre_angle=np.zeros(4),
                fixed_x=np.zeros(9, bool), fixed_y=np.zeros(9, bool))
    si = Scene().si()
    si.physics.element_deletion = False
    state = fem.build_state(mesh, si)
    state.params[P_EMAX] = 1e30  # the motion is imposed, not integrated: the energy guard has nothing to check
    props = state.props
    hist = np.zeros((1, N_HIST))
    a0 = float(state.area0[0])
    th = math.radians(35.0)
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    # simple shear with a slight compression, well past the shear yield: no crack opening (whose damage
    # depends on each element's size by design), so every element must carry the same stress
    for s in np.linspace(0.0, 1.0, 41)[1:]:
        G = s * np.array([[-0.02, 0.3], [0.0, -0.04]])
        F = R @ (np.eye(2) + G)
        pos = F @ np.vstack([X, Y])
        state.x[:], state.y[:] = pos[0], pos[1]
        assert fem.advance(state, 1, dt=1e-30).status == "ok"
        E = 0.5 * (F.T @ F - np.eye(2))
        ref = material_stress(props, 1, 1.0, 0.0, E[0, 0], E[1, 1], E[0, 1], 0.0, hist, 0, a0, False)
    assert hist[0, H_EQP] > 0.01 and hist[0, H_EQPT] == 0.0  # well past yield, no crack opening
    S = state.stress
    assert np.abs(S - S[0]).max() <= 1e-9 * np.abs(S[0]).max()
    assert np.abs(state.mhist - state.mhist[0]).max() <= 1e-9 * np.abs(state.mhist[0]).max()
    assert np.allclose(S[0, :3], ref[:3], rtol=1e-9, atol=1e-9 * np.abs(ref[:3]).max())
    f_int = math.hypot(state.fx[4], state.fy[4]) / np.abs(np.r_[state.fx, state.fy]).max()
    assert f_int < 1e-9


def test_fibre_reading_b_is_elastic_to_xc_then_flows_to_its_failure_strain():
    """Reading B of Table 1: a fibre compressed along its axis (uniaxial plane strain) is elastic up to Xc, then
    flows at Xc (no hardening) and fails at the engineering strain -0.155 (mode 3), not at Xc (mode 2); pulled,
    it fails brittly at the maximum principal stress Xt (mode 1)."""
    from solver.fem.materials import C11, SYC, XC, XT

    props = material_table(Scene().si())
    assert props[0, SYC] == pytest.approx(props[0, XC])
    e_y = props[0, XC] / props[0, C11]
    ep = 0.0
    modes, s11 = [], []
    for e_eng in np.linspace(0.0, -0.16, 1601):
        exx = 0.5 * ((1.0 + e_eng) ** 2 - 1.0)
        sxx, _, _, _, ep, mode = material_stress(props, 0, 1.0, 0.0, exx, 0.0, 0.0, ep, np.zeros((0, N_HIST)), 0, 1e-12, True)
        modes.append(mode)
        s11.append(sxx)
    modes, s11 = np.array(modes), np.array(s11)
    first = int(np.argmax(modes > 0))
    assert modes[first] == 3 and np.linspace(0.0, -0.16, 1601)[first] == pytest.approx(-0.155, abs=2e-4)
    flowing = np.linspace(0.0, -0.16, 1601)[:first] < -2 * e_y
    assert np.allclose(s11[:first][flowing], -props[0, XC], rtol=1e-9)
    for e_eng in np.linspace(0.0, 0.03, 301):
        mode = material_stress(props, 0, 1.0, 0.0, 0.5 * ((1 + e_eng) ** 2 - 1), 0.0, 0.0, 0.0, np.zeros((0, N_HIST)), 0,
                               1e-12, True)[5]
        if mode:
            break
    assert mode == 1 and e_eng == pytest.approx(props[0, XT] / props[0, C11], rel=0.01)
