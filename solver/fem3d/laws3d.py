"""Inelastic laws of the 3D engine: fibre, matrix, EHM (the 2D engine's laws on the full 3D tensor).

A law maps the Green-Lagrange strain E (global axes, tensor shears) and its element's history row to
the 2nd Piola-Kirchhoff stress S and a failure mode; the element (:mod:`.hex8`) only computes the
kinematics. The material frame of a total-Lagrangian law rotates with the body exactly, so the fibre
direction d is the reference one. Each material row m has its global 6x6 stiffness ``cmat[m]``
(:mod:`.material3d`) and a row of the property table ``props[m]`` whose columns 0 .. N_PROPS - 1 are
the 2D engine's (:mod:`solver.fem.materials`: KIND, strengths, LAW, UF, EPSF, EHM_DELETE, ...) and the
3D columns follow. The failure modes are the 2D engine's (``MODE_NAMES``), so the outputs read alike.

Kinds (props[m, KIND]):

* ELASTIC (3): S = C : E, never fails (the engine's elastic path, unchanged).
* fibre (0), transversely isotropic, axis 1 along d: S = C : (E - e_p d (x) d), the plastic strain
  e_p <= 0 along the fibre only. In compression along the fibre, elastic-plastic by a 1D return
  mapping on S11 = d . S . d (:func:`fibre_return`): yield sigma_yc, linear hardening H reaching Xc at
  the compressive failure strain eps_fc (the 2D law's rule, with C11 the fibre-frame C_1111, which
  is the 2D plane-strain C11). Failure: max principal stress (of the full 3D S) >= Xt (mode 1); with
  the fibre's plasticity off S11 <= -Xc (mode 2); the fibre's engineering strain
  sqrt(1 + 2 d.E.d) - 1 <= -eps_fc (mode 3).
* matrix (1), isotropic (lambda = C_12, 2G = C_11 - C_12):
  ``paraboloid`` (LAW 1): :func:`solver.fem.paraboloid.paraboloid_return` on the trial stress of the
  elastic strain E - E_p (the plastic strain tensor, all six components, in the history), the
  equivalent plastic strain and its part accumulated under a tensile mean stress; crack band
  d = l_c eqp_t / u_f with l_c = V0^(1/3) (the 2D law's sqrt(A0)), S = (1 - d) S_plastic; fails at
  d = 1 (mode 4) or when the equivalent plastic strain reaches eps_f (mode 12).
  ``brittle`` (LAW 0): elastic; fails when the max principal stress (3D) reaches sigma_u (mode 4), or,
  with a crack band (CBAND > 0), softens by :func:`solver.fem.materials.crack_band_damage` (kappa the
  largest max principal stress reached, the element's "area" passed as V0^(2/3) so its square root is
  l_c = V0^(1/3)) and fails at d = 1. The 3D table (:func:`material_table3d`) sets
  CBAND = 2 G_c E / sigma_u (the uniaxial-stress modulus E of a 3D body; the 2D table's plane-strain
  E / (1 - nu^2) where the caller asks for it, ``band_modulus='plane_strain'``).
* EHM (2), transversely isotropic about d, the 3D Hashin criteria (Hashin 1980, J. Appl. Mech.
  47:329, the three-dimensional forms), read from S in the material frame (invariants of the 2-3 plane, so only d is
  needed: S11 = d.S.d, S12^2 + S13^2 = |S d|^2 - S11^2, S22 + S33 = tr S - S11,
  S23^2 - S22 S33 = -(I2 - S11 (S22 + S33) + S12^2 + S13^2), I2 the second invariant of S):
  fibre tension (S11 >= 0): (S11/XT)^2 + (S12^2 + S13^2)/SL^2 >= 1 (mode 5);
  fibre compression (S11 < 0): (S11/XC)^2 >= 1 (mode 6);
  matrix tension (S22 + S33 >= 0): ((S22 + S33)/YT)^2 + (S23^2 - S22 S33)/ST^2 + (S12^2 + S13^2)/SL^2 >= 1
  (mode 7); matrix compression (S22 + S33 < 0): ((YC/(2 ST))^2 - 1)(S22 + S33)/YC + (S22 + S33)^2/(4 ST^2)
  + (S23^2 - S22 S33)/ST^2 + (S12^2 + S13^2)/SL^2 >= 1 (mode 8). In plane stress (S33 = S13 = S23 = 0)
  they are the 2D engine's. EHM_DELETE = 0: the element stays elastic and the mode comes back
  negative (overloaded), as in 2D.

S stands for the Cauchy stress in the material frame in the criteria (to within the strain), as in 2D.

History row (hist[e], N_HIST3 columns): crack-band kappa; plastic strain xx, yy, zz, xy, yz, zx (tensor
shears); equivalent plastic strain; its tensile part; the fibre's plastic strain e_p; the element's
hourglass damage (1 - the smallest secant ratio its centre has had, :func:`solver.fem3d.hex8.hourglass_scale`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..fem.materials import (CBAND, EHM_DELETE, EHM_KIND, EPSF, EPSFC, FIBRE_KIND, H_SL, H_ST, H_XC, H_XT, H_YC,
                             H_YT, HARD, KIND, LAW, LAW_PARABOLOID, MATRIX_KIND, MODE_NAMES, N_PROPS, NUP, PLASTIC, RHO,
                             SIGU, SYC, SYCM, UF, XC, XT, crack_band_damage, ehm_properties, material_table)

MODE_NAMES = MODE_NAMES  # the failure modes (the 2D numbers), re-exported for the 3D engine's users
from ..fem.paraboloid import equivalent_plastic_increment, flow_alpha, paraboloid_return
from ..tensor3 import sym_eig3
from .material3d import fibre_frame, fibre_stiffness, isotropic_stiffness, pk2_stress

#: the elastic kind (no plasticity, no failure): the engine's default
ELASTIC_KIND = 3
#: 3D columns after the 2D ones: the fibre (material axis 1) direction d; C : (d (x) d) in Voigt order;
#: the fibre-frame C_1111; lambda and 2G of an isotropic matrix
D0, D1, D2 = N_PROPS, N_PROPS + 1, N_PROPS + 2
CD0 = N_PROPS + 3  # .. CD0 + 5
CF11 = N_PROPS + 9
LAM, G2 = N_PROPS + 10, N_PROPS + 11
N_PROPS3 = N_PROPS + 12
#: history columns
H3_KAPPA, H3_EPXX, H3_EPYY, H3_EPZZ, H3_EPXY, H3_EPYZ, H3_EPZX, H3_EQP, H3_EQPT, H3_EPF, H3_HGD = range(11)
N_HIST3 = 11


def elastic_table(nm: int) -> np.ndarray:
    """The property table of ``nm`` elastic materials (kind ELASTIC: never fail)."""
    p = np.zeros((nm, N_PROPS3))
    p[:, KIND] = ELASTIC_KIND
    p[:, D0] = 1.0
    return p


def _fill_direction(row: np.ndarray, C: np.ndarray, d) -> None:
    Q = fibre_frame(d)
    d = Q[:, 0]
    row[D0:D2 + 1] = d
    dd = np.array([d[0] * d[0], d[1] * d[1], d[2] * d[2], 2 * d[0] * d[1], 2 * d[1] * d[2], 2 * d[2] * d[0]])
    row[CD0:CD0 + 6] = C @ dd  # C : (d (x) d), engineering shears
    row[CF11] = float(dd @ C @ dd)


def material_table3d(si, fibre_direction=(1.0, 0.0, 0.0), ehm_direction=None, mass_scaling: float = 1.0,
                     fibre_plasticity: bool = True, ehm_failure: bool = True, band_modulus: str = "3d"):
    """(cmat (3, 6, 6), rho (3,), props (3, N_PROPS3)) for material rows FIBRE=0, MATRIX=1, EHM=2 from an SI
    scene namespace (the 2D table's data, :func:`solver.fem.materials.material_table`), the fibre along
    ``fibre_direction`` and the EHM's axis 1 along ``ehm_direction`` (default: the fibre's).
    band_modulus: the brittle matrix's crack band with the 3D uniaxial-stress modulus E ('3d') or the 2D
    table's plane-strain E / (1 - nu^2) ('plane_strain')."""
    p2 = material_table(si, mass_scaling, fibre_plasticity, ehm_failure)
    props = np.zeros((3, N_PROPS3))
    props[:, :N_PROPS] = p2
    f, m = si.fibre, si.matrix
    h = ehm_properties(si)
    ehm_direction = fibre_direction if ehm_direction is None else ehm_direction
    cmat = np.stack([fibre_stiffness(f.E1, f.E2, f.G12, f.nu12, f.nu23, fibre_direction),
                     isotropic_stiffness(m.E, m.nu),
                     fibre_stiffness(h["E1"], h["E2"], h["G12"], h["nu12"], h["nu23"], ehm_direction)])
    _fill_direction(props[0], cmat[0], fibre_direction)
    _fill_direction(props[1], cmat[1], (1.0, 0.0, 0.0))
    _fill_direction(props[2], cmat[2], ehm_direction)
    props[1, LAM] = cmat[1, 0, 1]
    props[1, G2] = cmat[1, 0, 0] - cmat[1, 0, 1]
    gc = getattr(m, "fracture_energy", None)
    if props[1, LAW] != LAW_PARABOLOID and gc:
        if band_modulus == "3d":
            props[1, CBAND] = 2.0 * gc * m.E / m.sigma_u
        elif band_modulus != "plane_strain":
            raise ValueError(f"band_modulus = {band_modulus!r}: allowed '3d', 'plane_strain'")
    rho = props[:, RHO].copy()
    return cmat, rho, props


@numba.njit(cache=True, inline="always")
def max_principal(sxx, syy, szz, sxy, syz, szx):
    """Largest eigenvalue of the symmetric 3x3 tensor (:func:`solver.tensor3.sym_eig3`)."""
    return sym_eig3(sxx, syy, szz, sxy, syz, szx)[0]


@numba.njit(cache=True, inline="always")
def fibre_return(s11, ep, c11, syc, h):
    """The fibre's 1D compressive return mapping on S11 (the 2D law's rule, :mod:`solver.fem.materials`):
    yield f = -S11 - (sigma_yc + H |e_p|) > 0 gives Delta = f / (C11 + H), e_p <- e_p - Delta. Returns
    (e_p, Delta) (Delta = 0 when elastic)."""
    fy = -s11 - (syc + h * (-ep))
    if fy > 0.0:
        dl = fy / (c11 + h)
        return ep - dl, dl
    return ep, 0.0


@numba.njit(cache=True, inline="always")
def _fibre_frame_parts(d0, d1, d2, sxx, syy, szz, sxy, syz, szx):
    """(S11, S12^2 + S13^2, S22 + S33, S23^2 - S22 S33) of S in a frame whose axis 1 is d (module docstring)."""
    t0 = sxx * d0 + sxy * d1 + szx * d2
    t1 = sxy * d0 + syy * d1 + syz * d2
    t2 = szx * d0 + syz * d1 + szz * d2
    s11 = d0 * t0 + d1 * t1 + d2 * t2
    tau2 = max(t0 * t0 + t1 * t1 + t2 * t2 - s11 * s11, 0.0)
    s2233 = sxx + syy + szz - s11
    i2 = sxx * syy + syy * szz + szz * sxx - sxy * sxy - syz * syz - szx * szx
    det23 = i2 - s11 * s2233 + tau2
    return s11, tau2, s2233, -det23


@numba.njit(cache=True, inline="always")
def hashin3d(props, m, s11, tau2, s2233, t23):
    """The 3D Hashin mode (module docstring; 0 = none) from the material-frame parts."""
    sl2 = props[m, H_SL] ** 2
    st = props[m, H_ST]
    mode = 0
    if s11 >= 0.0:
        if (s11 / props[m, H_XT]) ** 2 + tau2 / sl2 >= 1.0:
            mode = 5
    elif (s11 / props[m, H_XC]) ** 2 >= 1.0:
        mode = 6
    if mode == 0:
        if s2233 >= 0.0:
            if (s2233 / props[m, H_YT]) ** 2 + t23 / (st * st) + tau2 / sl2 >= 1.0:
                mode = 7
        else:
            yc = props[m, H_YC]
            if (((yc / (2.0 * st)) ** 2 - 1.0) * s2233 / yc + s2233 * s2233 / (4.0 * st * st) + t23 / (st * st)
                    + tau2 / sl2 >= 1.0):
                mode = 8
    return mode


@numba.njit(cache=True, inline="always")
def law_stress(props, cmat, m, exx, eyy, ezz, exy, eyz, ezx, hist, e, v0, check):
    """Stress update of an inelastic material at one point (module docstring): Green-Lagrange E (tensor
    shears) -> S (xx, yy, zz, xy, yz, zx), updating hist[e]; v0 the element's reference volume. When
    ``check`` the failure criteria are evaluated. Returns (Sxx, Syy, Szz, Sxy, Syz, Szx, mode)."""
    kind = props[m, KIND]
    mode = 0
    if kind == MATRIX_KIND:
        if props[m, LAW] == LAW_PARABOLOID:
            lam = props[m, LAM]
            g2 = props[m, G2]
            kb = lam + g2 / 3.0
            nup = props[m, NUP]
            a = exx - hist[e, H3_EPXX]
            b = eyy - hist[e, H3_EPYY]
            c = ezz - hist[e, H3_EPZZ]
            tr = a + b + c
            sxx, syy, szz, sxy, syz, szx, dxx, dyy, dzz, dxy, dyz, dzx, dg = paraboloid_return(
                lam * tr + g2 * a, lam * tr + g2 * b, lam * tr + g2 * c, g2 * (exy - hist[e, H3_EPXY]),
                g2 * (eyz - hist[e, H3_EPYZ]), g2 * (ezx - hist[e, H3_EPZX]), 0.5 * g2, kb, props[m, SIGU],
                props[m, SYCM], flow_alpha(nup))
            if dg > 0.0:
                hist[e, H3_EPXX] += dxx
                hist[e, H3_EPYY] += dyy
                hist[e, H3_EPZZ] += dzz
                hist[e, H3_EPXY] += dxy
                hist[e, H3_EPYZ] += dyz
                hist[e, H3_EPZX] += dzx
                deq = equivalent_plastic_increment(dxx, dyy, dzz, dxy, dyz, dzx, nup)
                hist[e, H3_EQP] += deq
                if sxx + syy + szz > 0.0:  # flow under a tensile mean stress opens the crack band
                    hist[e, H3_EQPT] += deq
            d = min(1.0, v0 ** (1.0 / 3.0) * hist[e, H3_EQPT] / props[m, UF])
            r = 1.0 - d
            if check:
                if d >= 1.0:
                    mode = 4
                elif hist[e, H3_EQP] >= props[m, EPSF]:
                    mode = 12
            return r * sxx, r * syy, r * szz, r * sxy, r * syz, r * szx, mode
        sxx, syy, szz, sxy, syz, szx = pk2_stress(cmat, m, exx, eyy, ezz, exy, eyz, ezx)
        s1 = max_principal(sxx, syy, szz, sxy, syz, szx)
        if props[m, CBAND] > 0.0:
            if s1 > hist[e, H3_KAPPA]:
                hist[e, H3_KAPPA] = s1
            d = crack_band_damage(hist[e, H3_KAPPA], props[m, SIGU], props[m, CBAND], v0 ** (2.0 / 3.0))
            r = 1.0 - d
            if check and d >= 1.0:
                mode = 4
            return r * sxx, r * syy, r * szz, r * sxy, r * syz, r * szx, mode
        if check and s1 >= props[m, SIGU]:
            mode = 4
        return sxx, syy, szz, sxy, syz, szx, mode
    sxx, syy, szz, sxy, syz, szx = pk2_stress(cmat, m, exx, eyy, ezz, exy, eyz, ezx)
    d0 = props[m, D0]
    d1 = props[m, D1]
    d2 = props[m, D2]
    if kind == FIBRE_KIND:
        ep = hist[e, H3_EPF]
        plastic = props[m, PLASTIC] > 0.0
        if ep != 0.0 or plastic:
            # S = C : (E - e_p d (x) d)
            sxx -= ep * props[m, CD0]
            syy -= ep * props[m, CD0 + 1]
            szz -= ep * props[m, CD0 + 2]
            sxy -= ep * props[m, CD0 + 3]
            syz -= ep * props[m, CD0 + 4]
            szx -= ep * props[m, CD0 + 5]
        s11 = (d0 * (sxx * d0 + sxy * d1 + szx * d2) + d1 * (sxy * d0 + syy * d1 + syz * d2)
               + d2 * (szx * d0 + syz * d1 + szz * d2))
        if plastic:
            epn, dl = fibre_return(s11, ep, props[m, CF11], props[m, SYC], props[m, HARD])
            if dl > 0.0:
                hist[e, H3_EPF] = epn
                sxx += dl * props[m, CD0]
                syy += dl * props[m, CD0 + 1]
                szz += dl * props[m, CD0 + 2]
                sxy += dl * props[m, CD0 + 3]
                syz += dl * props[m, CD0 + 4]
                szx += dl * props[m, CD0 + 5]
                s11 += dl * props[m, CF11]
        if check:
            e11 = (d0 * (exx * d0 + exy * d1 + ezx * d2) + d1 * (exy * d0 + eyy * d1 + eyz * d2)
                   + d2 * (ezx * d0 + eyz * d1 + ezz * d2))
            if max_principal(sxx, syy, szz, sxy, syz, szx) >= props[m, XT]:
                mode = 1
            elif not plastic and s11 <= -props[m, XC]:
                mode = 2
            elif math.sqrt(max(1.0 + 2.0 * e11, 0.0)) - 1.0 <= -props[m, EPSFC]:
                mode = 3
        return sxx, syy, szz, sxy, syz, szx, mode
    if kind == EHM_KIND and check:
        s11, tau2, s2233, t23 = _fibre_frame_parts(d0, d1, d2, sxx, syy, szz, sxy, syz, szx)
        mode = hashin3d(props, m, s11, tau2, s2233, t23)
        if props[m, EHM_DELETE] == 0.0:
            mode = -mode  # overloaded, kept elastic
    return sxx, syy, szz, sxy, syz, szx, mode


@numba.njit(cache=True)
def law_point(props, cmat, m, E, hist_row, v0, check):
    """Compiled array form of :func:`law_stress` for tests and drivers: E (6,) tensor shears, hist_row
    (N_HIST3,) updated in place; returns (S (6,), mode)."""
    h = hist_row.reshape(1, -1)
    sxx, syy, szz, sxy, syz, szx, mode = law_stress(props, cmat, m, E[0], E[1], E[2], E[3], E[4], E[5], h, 0, v0,
                                                    check)
    out = np.empty(6)
    out[0] = sxx
    out[1] = syy
    out[2] = szz
    out[3] = sxy
    out[4] = syz
    out[5] = szx
    return out, mode
