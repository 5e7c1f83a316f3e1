"""The analytic fidelity: a mechanistic force model for orthogonal cutting of UD-CFRP.

Structure after Zhang, Zhang & Wang, Mach. Sci. Technol. 5 (2001) 293: the tool force is the
sum of three regions,

1. **chipping** (material above the separation point on the edge goes into the chip):
   Merchant's force circle on a separation plane at angle ``phi`` whose resistance depends on
   the angle between the plane and the fibres (interface/matrix shear along the fibres,
   fibre shear-yield across them); ``phi`` minimises the cutting force (Merchant's principle);
   the fibres crossing the cut plane are sheared across at the chip root;
2. **pressing** (material between the separation point and the lowest point of the round edge
   is pushed under the tool): contact pressure on the arc = plane-strain crushing pressure of
   the ply, capped by its elastic response, with Coulomb friction;
3. **bouncing** (the pressed layer and the elastic depression spring back by ``delta_b`` and
   press against the clearance face): plane-strain elastic contact force ``(pi/4) E_n delta_b``
   in series with the crushing limit over the contact length ``delta_b / tan(gamma)``.

The damage depth is the depth of the zone where the radial line-load stress field of the
total tool force in the orthotropic ply (Lekhnitskii; Flamant when isotropic) exceeds the
fibre-matrix interface (quadratic traction criterion) or the matrix (maximum principal
stress) strength.

Every material constant comes from ``scene.si()`` (fibre, matrix, interface, fibre volume
fraction; ply properties by the rule of mixtures). The derivation, the assumptions and the
limitations are in ``docs/analytic-model.md``. Pure Python ``math``: no numba, no numpy
work on the hot path, a call takes about 0.1 ms.

Conventions (docs/model.md, "The scene"): x = cutting direction, y = up; the tool moves in
+x relative to the workpiece; ``Fc`` resists the tool's motion, ``Ft`` is positive when the
workpiece pushes the tool up. All quantities here are SI per unit width (N/m) until
:func:`run_analytic` converts to user units (N/mm, um).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from . import units as u
from .result import Result

#: Plane-strain crushing pressure over flow stress for a blunt indenter (Prandtl flat punch,
#: Tresca: p = (2 + pi) k with k = sigma_flow / 2).
PRANDTL_FACTOR = 1.0 + math.pi / 2.0
#: beta - alpha on the rake face is used as is up to LAMBDA_KNEE_DEG and then saturates smoothly
#: towards LAMBDA_MAX_DEG (a tanh knee, continuous with its slope): at 90 deg Merchant's
#: construction has no admissible shear plane (strongly negative rake with high friction); a
#: sticking chip (dead zone) then limits the effective friction-minus-rake angle.
LAMBDA_KNEE_DEG = 60.0
LAMBDA_MAX_DEG = 80.0
#: Angle from the lowest point of the edge to the separation point (Basuray et al. 1977, beta = 0).
SEPARATION_ANGLE = math.pi / 4.0
N_PHI = 64  # separation-plane angles searched (Merchant's minimum)
N_RAY = 90  # directions searched for the damage depth


@dataclass(frozen=True)
class Ply:
    """Unidirectional ply properties by the rule of mixtures (SI)."""

    E1: float  # axial modulus, Voigt: Vf Ef1 + (1 - Vf) Em
    E2: float  # transverse modulus, Reuss: 1 / (Vf / Ef2 + (1 - Vf) / Em)
    G12: float  # in-plane shear modulus, Reuss with Gm = Em / (2 (1 + nu_m))
    nu12: float  # Voigt
    S_along: float  # shear resistance of a plane along the fibres: min(tau_interface, sigma_u matrix)
    T_across: float  # shear resistance of a plane across the fibres: Vf sigma_yc/sqrt(3) + (1 - Vf) S_along
    T_root: float  # fibre share of it, Vf sigma_yc / sqrt(3): severing the fibres at the chip root
    sigma_flow: float  # confined compressive flow stress: Vf sigma_yc + (1 - Vf) Em sigma_yc / Ef1
    sigma_n_int: float  # interface normal strength
    tau_int: float  # interface shear strength
    sigma_u_m: float  # matrix failure stress (maximum principal stress)


def ply_properties(si) -> Ply:
    """Rule-of-mixtures ply from the scene's fibre, matrix and interface (SI)."""
    vf = si.fibre_volume_fraction
    f, m, it = si.fibre, si.matrix, si.interface
    gm = m.E / (2.0 * (1.0 + m.nu))
    s_along = min(it.tau, m.sigma_u)  # matrix under pure shear fails when sigma_1 = tau = sigma_u
    # the ply's compressive flow stress: the weaker constituent's compressive yield (the fibre's in reading A
    # of the paper's Table 1, the matrix's in reading B; docs/analytic-model.md); a plane across the fibres
    # shears at it (von Mises)
    paraboloid = getattr(m, "law", "brittle") == "paraboloid"  # the brittle matrix has no compressive yield
    sigma_c = min(f.sigma_yc, m.sigma_yc) if paraboloid else f.sigma_yc
    tau_fibre = sigma_c / math.sqrt(3.0)
    return Ply(
        E1=vf * f.E1 + (1.0 - vf) * m.E,
        E2=1.0 / (vf / f.E2 + (1.0 - vf) / m.E),
        G12=1.0 / (vf / f.G12 + (1.0 - vf) / gm),
        nu12=vf * f.nu12 + (1.0 - vf) * m.nu,
        S_along=s_along,
        T_across=vf * tau_fibre + (1.0 - vf) * s_along,
        T_root=vf * tau_fibre,
        sigma_flow=vf * sigma_c + (1.0 - vf) * m.E * sigma_c / f.E1,
        sigma_n_int=it.sigma_n,
        tau_int=it.tau,
        sigma_u_m=m.sigma_u,
    )


def offaxis_modulus(ply: Ply, angle: float) -> float:
    """Young's modulus of the ply along a direction at ``angle`` to the fibres.

    Off-axis transformation (Jones, Mechanics of Composite Materials, 2nd ed., eq. 2.97):
    1/E = cos^4 / E1 + (1/G12 - 2 nu12/E1) sin^2 cos^2 + sin^4 / E2.
    """
    c2 = math.cos(angle) ** 2
    s2 = 1.0 - c2
    return 1.0 / (c2 * c2 / ply.E1 + (1.0 / ply.G12 - 2.0 * ply.nu12 / ply.E1) * s2 * c2 + s2 * s2 / ply.E2)


def normal_modulus(ply: Ply, theta: float) -> float:
    """Young's modulus normal to the cut surface (y) for fibres at ``theta``: the off-axis
    modulus at 90 deg - theta to the fibres (E2 at theta = 0, E1 at theta = 90)."""
    return offaxis_modulus(ply, 0.5 * math.pi - theta)


def effective_lambda(lam: float) -> float:
    """beta - alpha, saturated smoothly above LAMBDA_KNEE_DEG so that it stays below LAMBDA_MAX_DEG."""
    knee = math.radians(LAMBDA_KNEE_DEG)
    if lam <= knee:
        return lam
    span = math.radians(LAMBDA_MAX_DEG - LAMBDA_KNEE_DEG)
    return knee + span * math.tanh((lam - knee) / span)


def chipping(ply: Ply, theta: float, t: float, rake: float, beta: float) -> dict:
    """Region 1: Merchant's force circle with a fibre-angle dependent separation strength.

    Separation plane from the tool tip at angle phi to the cutting direction; the fibres make
    the angle psi = phi - theta with it. Resistance per unit plane area
    tau(psi) = S cos^2 psi + T sin^2 psi (S along the fibres, T across them). With the
    friction angle beta on the rake face (rake alpha), per unit width (Merchant 1945):
        F_s = tau t / sin(phi),  F_c = F_s cos(beta - alpha) / cos(phi + beta - alpha),
        F_t = F_s sin(beta - alpha) / cos(phi + beta - alpha).
    phi minimises F_c over the admissible range (0, 90 deg - (beta - alpha)); beta - alpha is
    saturated smoothly below 80 deg (:func:`effective_lambda`). The fibres that
    cross the cut plane are also cut at the chip root (fracture across the fibres):
        F_c,root = Vf tau_f t sin^2 theta,  tau_f = sigma_yc / sqrt(3).
    """
    lam = effective_lambda(beta - rake)
    cl, sl = math.cos(lam), math.sin(lam)
    lo = math.radians(1.0)
    hi = min(math.radians(89.0), math.radians(89.0) - lam)
    ct, st = math.cos(theta), math.sin(theta)
    S, dT = ply.S_along, ply.T_across - ply.S_along
    best, best_phi, best_tau = math.inf, lo, S
    step = (hi - lo) / (N_PHI - 1)
    for k in range(N_PHI):
        phi = lo + k * step
        sp, cp = math.sin(phi), math.cos(phi)
        spsi = sp * ct - cp * st  # sin(phi - theta)
        tau = S + dT * spsi * spsi
        g = tau / (sp * (cp * cl - sp * sl))  # tau / (sin phi cos(phi + lam))
        if g < best:
            best, best_phi, best_tau = g, phi, tau
    fs = best_tau * t / math.sin(best_phi)
    denom = math.cos(best_phi + lam)
    # fracture across the fibres at the chip root: the fibres crossing the cut plane (area
    # Vf |sin theta| per unit advance) are sheared across (yield tau_f) through the transverse
    # displacement t |sin theta| the chip imposes on them before they are released
    f_root = ply.T_root * t * st * st
    return {"Fc": fs * cl / denom + f_root, "Ft": fs * sl / denom, "phi": best_phi, "tau": best_tau, "Fs": fs,
            "lambda": lam, "F_root": f_root}


def separation(r: float, a: float, rake: float) -> tuple[float, float, float]:
    """Separation point on the round edge and the pressed thickness.

    Angle from the lowest point of the edge to the separation (stagnation) point:
    psi_s = pi/4, the frictionless slip-line value of Basuray et al. (1977) (their
    pi/4 - beta/2 lowers it with friction through plastic flow of a metal chip; a brittle
    composite separates by fracture, so friction does not move the point), at most the
    rake-face tangent point pi/2 - alpha. Material between it and the lowest point,
    h_s = r (1 - cos psi_s), is pressed under the tool; if the depth is smaller than h_s
    everything is pressed. Returns (psi_s, psi_p, h_p): psi_p is the arc angle of the
    pressing contact, h_p = min(h_s, a) the pressed thickness.
    """
    psi_s = min(SEPARATION_ANGLE, math.pi / 2.0 - rake)
    if r <= 0.0:
        return psi_s, 0.0, 0.0
    h_s = r * (1.0 - math.cos(psi_s))
    if h_s <= a:
        return psi_s, psi_s, h_s
    return psi_s, math.acos(1.0 - a / r), a


def pressing(ply: Ply, e_n: float, r: float, psi_p: float, mu: float) -> dict:
    """Region 2: pressure p on the arc 0 <= psi <= psi_p under the edge, with friction mu.

    p = H p_el / (H + p_el): the crushing pressure H = (1 + pi/2) sigma_flow in series with the
    elastic pressure p_el = E_n tan(psi_p / 2) (the mean strain of the pressed zone is its
    interference over its contact length, r (1 - cos psi_p) / (r sin psi_p)). The traction
    on the tool at arc angle psi is p (-sin psi, cos psi) + mu p (-cos psi, -sin psi) (the
    material flows down and back under the edge); integrated over r dpsi:
        F_c = p r [(1 - cos psi_p) + mu sin psi_p],  F_t = p r [sin psi_p - mu (1 - cos psi_p)].
    """
    hardness = PRANDTL_FACTOR * ply.sigma_flow
    p_el = e_n * math.tan(0.5 * psi_p)
    p = hardness * p_el / (hardness + p_el) if p_el > 0.0 else 0.0
    omc, s = 1.0 - math.cos(psi_p), math.sin(psi_p)
    return {"Fc": p * r * (omc + mu * s), "Ft": p * r * (s - mu * omc), "pressure": p, "hardness": hardness,
            "contact_length": r * s}


def bouncing(ply: Ply, e_n: float, h_p: float, ft_press: float, clearance: float, mu: float) -> dict:
    """Region 3: spring-back of the surface against the clearance face.

    Bounce-back delta_b = h_p + delta_e: the pressed layer is not removed (plane strain,
    nearly incompressible crushed material), so it reappears behind the edge, and the
    elastic depression under the edge load recovers, delta_e = 2 F_t,press / (pi E_n)
    (2D half-space under a strip load, displacement relative to a depth of the order of the
    contact length). The normal force on the clearance face is
        N = delta_b K,  K = (pi/4) E_n H / ((pi/4) E_n tan(gamma) + H),
    the plane-strain elastic contact stiffness (pi/4) E_n (Zhang et al. 2001 form) in series
    with the crushing limit H over the contact length delta_b / tan(gamma). The face is
    inclined by gamma; friction mu as the surface slides back along it:
        F_c = N (mu cos gamma - sin gamma),  F_t = N (cos gamma + mu sin gamma).
    """
    hardness = PRANDTL_FACTOR * ply.sigma_flow
    delta_e = 2.0 * max(ft_press, 0.0) / (math.pi * e_n)
    delta_b = h_p + delta_e
    k_el = 0.25 * math.pi * e_n
    tg = math.tan(clearance)
    stiff = k_el * hardness / (k_el * tg + hardness)
    n = stiff * delta_b
    cg, sg = math.cos(clearance), math.sin(clearance)
    contact = delta_b / tg if tg > 0.0 else math.inf
    return {"Fc": n * (mu * cg - sg), "Ft": n * (cg + mu * sg), "normal": n, "bounce_back": delta_b,
            "elastic_recovery": delta_e, "contact_length": contact}


def damage_depth(ply: Ply, theta: float, fc: float, ft: float) -> float:
    """Depth below the cut plane of the zone the tool force damages.

    The tool force (F_c, -F_t) acts on the workpiece as a line load on the edge of an
    orthotropic half-plane. Its stress is purely radial (Lekhnitskii's radial distribution,
    Anisotropic Plates, 1968; Flamant's solution when isotropic):
        sigma_r = -E(v) (A cos v + B sin v) / rho
    along e_r = (cos v, -sin v), v in (0, pi) measured downward from the cutting direction,
    with E(v) the ply modulus along e_r (the load channels along the fibres), and A, B from
    equilibrium of a half-disc, int E(v) (A cos v + B sin v) e_r dv = (F_c, -F_t).
    Tractions on planes parallel to the fibres (n = (-sin theta, cos theta)):
    sigma_nn = sigma_r sin^2(v + theta), tau = -sigma_r sin(v + theta) cos(v + theta).
    The interface fails where (<sigma_nn>/sigma_n)^2 + (tau/tau_s)^2 >= 1, the matrix where
    the tensile sigma_r >= sigma_u. Both fall as 1/rho, so each criterion gives a radius
    rho(v); the damage depth is max_v rho(v) sin v. The same midpoint rule over N_RAY
    directions serves the equilibrium integrals and the search, so equilibrium holds exactly
    on the discrete rays.
    """
    h = math.pi / N_RAY
    rays = []
    icc = ics = iss = 0.0
    for k in range(N_RAY):
        v = (k + 0.5) * h
        cv, sv = math.cos(v), math.sin(v)
        e = offaxis_modulus(ply, v + theta)
        icc += e * cv * cv
        ics += e * cv * sv
        iss += e * sv * sv
        rays.append((v, cv, sv, e))
    # int E (A c + B s) c dv = F_c ;  int E (A c + B s) s dv = F_t   (midpoint rule, weight h)
    det = (icc * iss - ics * ics) * h
    a_coef = (fc * iss - ft * ics) / det
    b_coef = (ft * icc - fc * ics) / det
    best = 0.0
    sn, ts, su = ply.sigma_n_int, ply.tau_int, ply.sigma_u_m
    for v, cv, sv, e in rays:
        w = e * (a_coef * cv + b_coef * sv)  # sigma_r * rho = -w: compressive where w > 0
        s, c = math.sin(v + theta), math.cos(v + theta)
        tens = max(-w, 0.0)
        rho_i = math.hypot(tens * s * s / sn, w * s * c / ts)
        rho_m = tens / su
        d = max(rho_i, rho_m) * sv
        if d > best:
            best = d
    return best


def analytic_forces(si) -> dict:
    """The whole model in SI (forces per unit width in N/m, lengths in m, angles in rad)."""
    ply = ply_properties(si)
    theta = si.fibre_angle
    mu, rake, r, a = si.friction, si.rake, si.edge_radius, si.depth
    beta = math.atan(mu)
    e_n = normal_modulus(ply, theta)
    psi_s, psi_p, h_p = separation(r, a, rake)
    t = max(a - h_p, 0.0)
    chip = chipping(ply, theta, t, rake, beta)
    press = pressing(ply, e_n, r, psi_p, mu)
    bounce = bouncing(ply, e_n, h_p, press["Ft"], si.clearance, mu)
    fc = chip["Fc"] + press["Fc"] + bounce["Fc"]
    ft = chip["Ft"] + press["Ft"] + bounce["Ft"]
    return {
        "Fc": fc, "Ft": ft, "chip": chip, "press": press, "bounce": bounce, "ply": ply, "E_n": e_n,
        "psi_s": psi_s, "psi_p": psi_p, "h_p": h_p, "t_chip": t, "beta": beta,
        "damage_depth": damage_depth(ply, theta, fc, ft),
    }


def run_analytic(scene) -> Result:
    """The analytic fidelity's run: summary metrics in user units, no time series, steps = 0."""
    t0 = time.perf_counter()
    si = scene.si()
    m = analytic_forces(si)
    n_mm, um, deg = u.force_to_n_per_mm, u.length_to_um, math.degrees
    chip, press, bounce = m["chip"], m["press"], m["bounce"]
    metrics = {
        "cutting_force_N_per_mm": n_mm(m["Fc"]),
        "thrust_force_N_per_mm": n_mm(m["Ft"]),
        "damage_depth_um": um(m["damage_depth"]),
        "bounce_back_um": um(bounce["bounce_back"]),
        "energy_error": 0.0,
        "chipping_cutting_force_N_per_mm": n_mm(chip["Fc"]),
        "chipping_thrust_force_N_per_mm": n_mm(chip["Ft"]),
        "pressing_cutting_force_N_per_mm": n_mm(press["Fc"]),
        "pressing_thrust_force_N_per_mm": n_mm(press["Ft"]),
        "bouncing_cutting_force_N_per_mm": n_mm(bounce["Fc"]),
        "bouncing_thrust_force_N_per_mm": n_mm(bounce["Ft"]),
        "shear_plane_angle_deg": deg(chip["phi"]),
        "separation_angle_deg": deg(m["psi_s"]),
        "pressed_thickness_um": um(m["h_p"]),
        "chip_thickness_um": um(m["t_chip"]),
        "normal_modulus_GPa": m["E_n"] / u.GPA,
    }
    contact_um = um(bounce["contact_length"])
    if math.isfinite(contact_um):  # unbounded for a zero clearance angle: then not reported
        metrics["clearance_contact_length_um"] = contact_um
    result = Result(scene=scene, status="ok", metrics=metrics, steps=0)
    if m["t_chip"] <= 0.0:
        result.warnings.append("depth of cut below the separation point of the edge: no chip forms, the edge only "
                               "presses and rubs (pressing and bouncing regions only)")
    result.build = {"model": "analytic (chipping + pressing + bouncing, after Zhang, Zhang & Wang 2001)",
                    "ply_E1_GPa": m["ply"].E1 / u.GPA, "ply_E2_GPa": m["ply"].E2 / u.GPA,
                    "ply_G12_GPa": m["ply"].G12 / u.GPA}
    result.wall_time_s = time.perf_counter() - t0
    return result
