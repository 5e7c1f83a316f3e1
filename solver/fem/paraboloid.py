"""The epoxy's pressure-dependent plasticity: the paraboloidal yield criterion and its return mapping.

Yield function (Tschoegl 1971, Polym. Eng. Sci. 11:308; used for epoxy matrices in
micro-mechanical models by Melro, Camanho, Andrade Pires & Pinho 2013, Int. J. Solids Struct.
50:1897, eq. 2):

    f(sigma) = 6 J2 + 2 I1 (sigma_c - sigma_t) - 2 sigma_c sigma_t <= 0

with I1 = tr(sigma), J2 = s:s / 2 (s the deviator), sigma_t and sigma_c the yield stresses in
uniaxial tension and compression. It passes through both uniaxial points; pure shear yields at
tau_y = sqrt(sigma_c sigma_t / 3), hydrostatic tension at p = sigma_c sigma_t / (3 (sigma_c -
sigma_t)). A matrix much stronger in compression than in tension (sigma_c = 8 sigma_t here) flows
in shear at about 1.6 sigma_t and under the tool's pressure at its compressive yield.

Flow (non-associated, Melro et al. 2013, eq. 5): potential g = sigma_vm^2 + alpha p^2
(sigma_vm^2 = 3 J2, p = I1 / 3) with alpha = 9 (1 - 2 nu_p) / (2 (1 + nu_p)), nu_p the plastic
Poisson ratio, so that a uniaxial plastic flow contracts laterally by nu_p:

    d eps_p = d gamma (3 s + (2 alpha p / 3) I).

Return mapping (implicit, closest to the end of the step; isotropic elasticity, shear modulus G,
bulk modulus K): with the trial state (s_tr, p_tr) the end state is

    s = s_tr / (1 + 6 G dgamma),  p = p_tr / (1 + 2 alpha K dgamma),

and dgamma >= 0 solves F(dgamma) = 6 J2_tr / (1 + 6 G dgamma)^2 + 6 p_tr (sigma_c - sigma_t) /
(1 + 2 alpha K dgamma) - 2 sigma_c sigma_t = 0. F(0) = f(trial) > 0 and F -> -2 sigma_c sigma_t
< 0, so a root is bracketed; it is found by Newton's method kept inside the bracket (bisection
when a Newton step leaves it). Perfect plasticity: sigma_t and sigma_c do not harden.

The functions work on the full 3D tensor (components xx, yy, zz, xy, yz, zx; tensor shear), so
the plane-strain element and a 3D element call the same code (plane strain: yz = zx = 0 and the
total eps_zz = 0, so the plastic eps_zz shows up as an elastic one of the opposite sign).
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always")
def flow_alpha(nu_p):
    """alpha of the flow potential g = sigma_vm^2 + alpha p^2 for a plastic Poisson ratio nu_p."""
    return 4.5 * (1.0 - 2.0 * nu_p) / (1.0 + nu_p)


@numba.njit(cache=True, inline="always")
def paraboloid_yield(sxx, syy, szz, sxy, syz, szx, sig_t, sig_c):
    """f(sigma) = 6 J2 + 2 I1 (sigma_c - sigma_t) - 2 sigma_c sigma_t (module docstring) [Pa^2]."""
    p = (sxx + syy + szz) / 3.0
    dx = sxx - p
    dy = syy - p
    dz = szz - p
    j2 = 0.5 * (dx * dx + dy * dy + dz * dz) + sxy * sxy + syz * syz + szx * szx
    return 6.0 * j2 + 6.0 * p * (sig_c - sig_t) - 2.0 * sig_c * sig_t


@numba.njit(cache=True)
def paraboloid_return(sxx, syy, szz, sxy, syz, szx, G, K, sig_t, sig_c, alpha):
    """Return a trial stress to the paraboloid (module docstring).

    Takes the trial (elastic predictor) stress; returns the end-of-step stress and the plastic
    strain increment, (sxx, syy, szz, sxy, syz, szx, dexx, deyy, dezz, dexy, deyz, dezx, dgamma),
    tensor shear components. A trial stress inside the surface comes back unchanged with zero
    increments.
    """
    f_tr = paraboloid_yield(sxx, syy, szz, sxy, syz, szx, sig_t, sig_c)
    if f_tr <= 0.0:
        return sxx, syy, szz, sxy, syz, szx, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    p_tr = (sxx + syy + szz) / 3.0
    dx = sxx - p_tr
    dy = syy - p_tr
    dz = szz - p_tr
    j2_tr = 0.5 * (dx * dx + dy * dy + dz * dz) + sxy * sxy + syz * syz + szx * szx
    a = 6.0 * G
    b = 2.0 * alpha * K
    c_p = 6.0 * p_tr * (sig_c - sig_t)
    c_0 = 2.0 * sig_c * sig_t
    # bracket: F(lo) > 0 >= F(hi)
    lo = 0.0
    hi = 1.0 / max(a, 1e-300)
    for _ in range(200):
        F = 6.0 * j2_tr / (1.0 + a * hi) ** 2 + c_p / (1.0 + b * hi) - c_0
        if F <= 0.0:
            break
        lo = hi
        hi *= 4.0
    x = lo
    for _ in range(100):
        ua = 1.0 + a * x
        ub = 1.0 + b * x
        F = 6.0 * j2_tr / (ua * ua) + c_p / ub - c_0
        if F > 0.0:
            lo = x
        else:
            hi = x
        dF = -12.0 * j2_tr * a / (ua * ua * ua) - c_p * b / (ub * ub)
        xn = x - F / dF if dF != 0.0 else 0.5 * (lo + hi)
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 1e-13 * max(xn, 1e-300) or hi - lo <= 1e-14 * hi:
            x = xn
            break
        x = xn
    dg = x
    rs = 1.0 / (1.0 + a * dg)
    p = p_tr / (1.0 + b * dg)
    nx = dx * rs
    ny = dy * rs
    nz = dz * rs
    nxy = sxy * rs
    nyz = syz * rs
    nzx = szx * rs
    vol = 2.0 * alpha * p / 3.0
    return (nx + p, ny + p, nz + p, nxy, nyz, nzx,
            dg * (3.0 * nx + vol), dg * (3.0 * ny + vol), dg * (3.0 * nz + vol),
            dg * 3.0 * nxy, dg * 3.0 * nyz, dg * 3.0 * nzx, dg)


@numba.njit(cache=True, inline="always")
def equivalent_plastic_increment(dexx, deyy, dezz, dexy, deyz, dezx, nu_p):
    """sqrt(d eps_p : d eps_p / (1 + 2 nu_p^2)), the equivalent plastic strain increment (Melro et al. 2013,
    eq. 7; tensor shear components): in uniaxial stress it is the axial plastic strain."""
    return math.sqrt((dexx * dexx + deyy * deyy + dezz * dezz + 2.0 * (dexy * dexy + deyz * deyz + dezx * dezx))
                     / (1.0 + 2.0 * nu_p * nu_p))
