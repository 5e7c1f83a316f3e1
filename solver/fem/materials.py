"""Material models of the FEM engine (docs/model.md): fibre, matrix, EHM.

All three share one form: an orthotropic plane-strain stiffness in the element's material
frame (axis 1 = fibre direction at the in-plane angle phi from x, axis 2 in-plane transverse,
axis 3 out of plane), applied to the Green-Lagrange strain E (total-Lagrangian, so the
material frame rotates with the body exactly) to give the 2nd Piola-Kirchhoff stress S:

    S11 = C11 (E11 - Ep) + C12 E22,  S22 = C12 (E11 - Ep) + C22 E22,  S12 = 2 C66 E12,
    S33 = C13 (E11 - Ep) + C23 E22   (plane strain, E33 = 0)

The plane-strain constants come from inverting the 3D compliance of a transversely isotropic
solid (axis 1 the symmetry axis): S11 = 1/E1, S22 = S33 = 1/E2, S12 = S13 = -nu12/E1,
S23 = -nu23/E2, and C66 = G12 (e.g. Jones, "Mechanics of Composite Materials", 2nd ed., 2.4).

Failure (a failed element is deleted by the loop), stresses S in the material frame, in-plane:

* fibre  (kind 0): max principal stress >= Xt (brittle tension); in compression along the
  fibre elastic-plastic (1D return mapping on S11, Ep <= 0) from the compressive yield
  sigma_yc with linear hardening H reaching Xc at the compressive failure strain eps_fc
  (reading B of the paper's Table 1: sigma_yc = Xc, H = 0, perfectly plastic at Xc), failing
  when the fibre's engineering strain reaches -eps_fc (paper 2.2.1); an elastic fibre
  (``physics.fibre_plasticity`` off) fails at S11 <= -Xc.
* matrix (kind 1), isotropic, one of two laws (``materials.matrix.law``):
  ``paraboloid``: elastic-plastic with the pressure-dependent paraboloidal yield surface
  (:mod:`.paraboloid`; yield sigma_u in tension, the compressive yield in compression), the plastic
  strain tensor in the element's history; tensile failure regularised by a crack band: the
  equivalent plastic strain accumulated under a tensile mean stress, times the element's size
  l_c = sqrt(A0), is a crack opening u, and the stress is (1 - d) times the plastic one with
  d = u / u_f, u_f = 2 G_c / sigma_u (linear softening; Bazant & Oh 1983, Mater. Struct. 16:155,
  in the plastic-displacement form of e.g. Abaqus' ductile damage evolution), so that the element
  dissipates G_c per unit crack length whatever its size and fails at d = 1 (mode 4); under
  shear and compression the matrix flows and fails (mode 12) when its equivalent plastic strain
  reaches the ductile failure strain eps_f.
  ``brittle`` (the paper's reading A): elastic until the max principal stress reaches sigma_u,
  then the element fails; optionally (``materials.matrix.fracture_energy_N_mm``) a crack band
  (Bazant & Oh 1983): past sigma_u the element softens linearly, dissipating G_c per unit crack
  length (:func:`crack_band_damage`), and fails when fully damaged.
* EHM    (kind 2): orthotropic, rule of mixtures (see :func:`ehm_properties`), 2D Hashin
  (Hashin 1980, J. Appl. Mech. 47:329): fibre tension (S11/XT)^2 + (S12/SL)^2 >= 1,
  fibre compression (S11/XC)^2 >= 1, matrix tension (S22/YT)^2 + (S12/SL)^2 >= 1,
  matrix compression (S22/2ST)^2 + ((YC/2ST)^2 - 1) S22/YC + (S12/SL)^2 >= 1.
  By default (``physics.ehm_failure`` off) the EHM stands for the elastic far field of a
  workpiece much larger than the cut-out: an element that meets a criterion stays elastic and
  is marked overloaded (the mode comes back negative), so a run says when its far field, not
  the material at the tool, would have decided the forces.

S is the corotated stress to within the strain (a few % before any failure), so the
criteria read it as the Cauchy stress in the material frame.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .paraboloid import equivalent_plastic_increment, flow_alpha, paraboloid_return

FIBRE_KIND, MATRIX_KIND, EHM_KIND = 0, 1, 2

# property table columns (props[material_id, column])
RHO, C11, C12, C22, C66, C13, C23, KIND = 0, 1, 2, 3, 4, 5, 6, 7
XT, XC, SYC, HARD, EPSFC, PLASTIC, SIGU = 8, 9, 10, 11, 12, 13, 14
H_XT, H_XC, H_YT, H_YC, H_SL, H_ST = 15, 16, 17, 18, 19, 20
CMAX = 21  # fastest wave speed of the material [m/s] (stiffest direction, scaled density)
#: matrix crack band: 2 G_c E' / sigma_u [Pa m] (0 = the paper's brittle failure), E' = E / (1 - nu^2)
#: the plane-strain uniaxial-stress modulus; the final effective stress of an element of size l_c is
#: this over l_c (:func:`crack_band_damage`)
CBAND = 22
#: matrix law (0 brittle, 1 paraboloid), compressive yield [Pa], plastic Poisson ratio nu_p,
#: crack-band failure opening u_f = 2 G_c / sigma_u [m], ductile failure strain eps_f
LAW, SYCM, NUP, UF, EPSF = 23, 24, 25, 26, 27
#: EHM: 1 = an element whose Hashin criterion is reached is deleted; 0 = it stays elastic and is marked
#: overloaded (the failure mode returned negative: solver.cutting reports where the far field was overloaded)
EHM_DELETE = 28
N_PROPS = 29
#: the matrix's history columns (state ``mhist``): crack-band kappa [Pa]; plastic strain Exx, Eyy, Exy, Ezz;
#: equivalent plastic strain; its part accumulated under a tensile mean stress
H_KAPPA, H_EPXX, H_EPYY, H_EPXY, H_EPZZ, H_EQP, H_EQPT = range(7)
N_HIST = 7
LAW_BRITTLE, LAW_PARABOLOID = 0.0, 1.0

# failure modes (also used for cohesive elements and the event log)
MODE_NAMES = ("none", "fibre tension (max principal >= Xt)", "fibre compression (S11 <= -Xc)",
              "fibre compression strain (<= -eps_fc)", "matrix tension (max principal >= sigma_u, or its crack band open)",
              "EHM fibre tension (Hashin)", "EHM fibre compression (Hashin)", "EHM matrix tension (Hashin)",
              "EHM matrix compression (Hashin)", "inverted element (deleted)",
              "cohesive fully damaged", "cohesive: tied element deleted",
              "matrix ductile (equivalent plastic strain >= eps_f)")


def plane_strain_stiffness(E1, E2, G12, nu12, nu23):
    """(C11, C12, C22, C66, C13, C23) of a transversely isotropic solid in plane strain.

    Inverts the 3x3 normal-compliance block [[1/E1, -nu12/E1, -nu12/E1], [-nu12/E1, 1/E2,
    -nu23/E2], [-nu12/E1, -nu23/E2, 1/E2]]; C66 = G12.
    """
    s = np.array([[1 / E1, -nu12 / E1, -nu12 / E1],
                  [-nu12 / E1, 1 / E2, -nu23 / E2],
                  [-nu12 / E1, -nu23 / E2, 1 / E2]])
    c = np.linalg.inv(s)
    return float(c[0, 0]), float(c[0, 1]), float(c[1, 1]), float(G12), float(c[0, 2]), float(c[1, 2])


def max_wave_speed(c11, c12, c22, c66, rho):
    """Fastest plane wave speed bound sqrt(lambda_max / rho) of the in-plane stiffness.

    lambda_max is the largest eigenvalue of the Mandel form [[C11, C12, 0], [C12, C22, 0],
    [0, 0, 2 C66]], which is invariant under in-plane rotation and bounds every eigenvalue of
    the acoustic tensor C_ijkl n_j n_l (for the fibre: the fibre-direction wave speed).
    """
    m = np.array([[c11, c12, 0.0], [c12, c22, 0.0], [0.0, 0.0, 2.0 * c66]])
    return math.sqrt(float(np.linalg.eigvalsh(m).max()) / rho)


def ehm_properties(si):
    """Equivalent homogeneous material by the rule of mixtures (our choice; documented).

    E1 = Vf E1f + (1-Vf) Em; 1/E2 = Vf/E2f + (1-Vf)/Em; 1/G12 = Vf/G12f + (1-Vf)/Gm;
    1/G23 = Vf/G23f + (1-Vf)/Gm; nu12 = Vf nu12f + (1-Vf) num; nu23 = E2/(2 G23) - 1
    (clipped to [0, 0.49]); rho = Vf rho_f + (1-Vf) rho_m. Strengths: XT = Vf Xt, XC = Vf Xc; the
    transverse and shear strengths YT, YC, SL, ST are the ply's (``materials.ehm``, docs/model.md).
    """
    f, m, vf = si.fibre, si.matrix, float(si.fibre_volume_fraction)
    gm = m.E / (2 * (1 + m.nu))
    e1 = vf * f.E1 + (1 - vf) * m.E
    e2 = 1 / (vf / f.E2 + (1 - vf) / m.E)
    g12 = 1 / (vf / f.G12 + (1 - vf) / gm)
    g23 = 1 / (vf / f.G23 + (1 - vf) / gm)
    nu12 = vf * f.nu12 + (1 - vf) * m.nu
    nu23 = min(max(e2 / (2 * g23) - 1, 0.0), 0.49)
    rho = vf * f.rho + (1 - vf) * m.rho
    h = si.ehm
    return dict(E1=e1, E2=e2, G12=g12, nu12=nu12, nu23=nu23, rho=rho, XT=vf * f.Xt, XC=vf * f.Xc,
                YT=h.yt, YC=h.yc, SL=h.shear_strength, ST=h.transverse_shear_strength)


def material_table(si, mass_scaling: float = 1.0, fibre_plasticity: bool = True, ehm_failure: bool = True) -> np.ndarray:
    """props[3, N_PROPS] for material ids FIBRE=0, MATRIX=1, EHM=2 from an SI scene namespace.

    Densities are multiplied by ``mass_scaling``; the wave speeds in column CMAX use the
    scaled density (they set the stable step). ``ehm_failure`` off: the EHM is marked overloaded
    instead of deleted (module docstring).
    """
    p = np.zeros((3, N_PROPS))
    f, m = si.fibre, si.matrix
    # fibre
    c = plane_strain_stiffness(f.E1, f.E2, f.G12, f.nu12, f.nu23)
    p[0, C11:C23 + 1] = c
    p[0, RHO] = f.rho * mass_scaling
    p[0, KIND] = FIBRE_KIND
    p[0, XT], p[0, XC], p[0, SYC], p[0, EPSFC] = f.Xt, f.Xc, f.sigma_yc, f.eps_fc
    eps_y = f.sigma_yc / c[0]
    p[0, HARD] = (f.Xc - f.sigma_yc) / max(f.eps_fc - eps_y, 1e-12)
    p[0, PLASTIC] = 1.0 if fibre_plasticity else 0.0
    # matrix (isotropic)
    c = plane_strain_stiffness(m.E, m.E, m.E / (2 * (1 + m.nu)), m.nu, m.nu)
    p[1, C11:C23 + 1] = c
    p[1, RHO] = m.rho * mass_scaling
    p[1, KIND] = MATRIX_KIND
    p[1, SIGU] = m.sigma_u
    gc = getattr(m, "fracture_energy", None)
    if getattr(m, "law", "brittle") == "paraboloid":
        p[1, LAW] = LAW_PARABOLOID
        p[1, SYCM] = m.sigma_yc
        p[1, NUP] = m.nu_p
        p[1, UF] = 2.0 * gc / m.sigma_u
        p[1, EPSF] = m.eps_f
    elif gc:
        p[1, CBAND] = 2.0 * gc * (m.E / (1.0 - m.nu ** 2)) / m.sigma_u
    # EHM
    h = ehm_properties(si)
    c = plane_strain_stiffness(h["E1"], h["E2"], h["G12"], h["nu12"], h["nu23"])
    p[2, C11:C23 + 1] = c
    p[2, RHO] = h["rho"] * mass_scaling
    p[2, KIND] = EHM_KIND
    p[2, H_XT], p[2, H_XC], p[2, H_YT], p[2, H_YC], p[2, H_SL], p[2, H_ST] = (
        h["XT"], h["XC"], h["YT"], h["YC"], h["SL"], h["ST"])
    p[2, EHM_DELETE] = 1.0 if ehm_failure else 0.0
    for i in range(3):
        p[i, CMAX] = max_wave_speed(p[i, C11], p[i, C12], p[i, C22], p[i, C66], p[i, RHO])
    return p


def uniaxial_moduli(props, mat, phi, beta):
    """Plane-strain uniaxial moduli along the directions beta and beta + 90 deg (vectorised).

    For each element: the in-plane stiffness of its material at angle phi (fibre), expressed in
    the frame rotated by beta (the element's local axis), inverted; returns (1/S'11, 1/S'22),
    the modulus of a fibre of material pulled along each axis with the other stresses free.
    These set the bending stiffness of the assumed-strain hourglass modes (:mod:`.quad`).
    """
    n = mat.shape[0]
    pr = props[mat]
    C = np.zeros((n, 3, 3))
    C[:, 0, 0], C[:, 0, 1], C[:, 1, 0], C[:, 1, 1], C[:, 2, 2] = pr[:, C11], pr[:, C12], pr[:, C12], pr[:, C22], pr[:, C66]
    th = phi - beta  # material axis relative to the element axis
    c, s = np.cos(th), np.sin(th)
    # strain transformation (engineering shear) from element frame to material frame: e_m = T e_l
    T = np.zeros((n, 3, 3))
    T[:, 0, 0], T[:, 0, 1], T[:, 0, 2] = c * c, s * s, c * s
    T[:, 1, 0], T[:, 1, 1], T[:, 1, 2] = s * s, c * c, -c * s
    T[:, 2, 0], T[:, 2, 1], T[:, 2, 2] = -2 * c * s, 2 * c * s, c * c - s * s
    Cl = np.einsum("nji,njk,nkl->nil", T, C, T)  # C_local = T^T C T
    S = np.linalg.inv(Cl)
    return 1.0 / S[:, 0, 0], 1.0 / S[:, 1, 1]


@numba.njit(cache=True, inline="always")
def crack_band_damage(kappa, sigma_u, cband, a0):
    """Damage d of a softening matrix element (crack band, Bazant & Oh 1983, Mater. Struct. 16:155).

    kappa is the largest maximum principal stress the undamaged (effective) stress has reached,
    sigma_u the strength, l_c = sqrt(A0) the element's crack-band width and
    k_f = cband / l_c = 2 G_c E' / (sigma_u l_c) the effective stress at full damage. Linear
    softening in the uniaxial stress-strain curve, sigma = (1 - d) kappa falling from sigma_u at
    kappa = sigma_u to 0 at kappa = k_f:

        d = k_f (kappa - sigma_u) / (kappa (k_f - sigma_u)),  0 <= d <= 1,

    so the work per unit volume to full damage is sigma_u k_f / (2 E') = G_c / l_c, and the element
    dissipates G_c per unit length of the crack it carries. An element too large for G_c
    (k_f <= sigma_u: snap-back) softens over 1 % of the onset strain instead, i.e. fails brittly,
    as in the paper. Returns d.
    """
    if kappa <= sigma_u:
        return 0.0
    kf = max(cband / math.sqrt(a0), 1.01 * sigma_u)
    if kappa >= kf:
        return 1.0
    return kf * (kappa - sigma_u) / (kappa * (kf - sigma_u))


@numba.njit(cache=True, inline="always")
def paraboloid_matrix_stress(props, m, exx, eyy, exy, hist, e, a0):
    """The ``paraboloid`` matrix law at one integration point (module docstring): Green-Lagrange E
    (global, tensor shear; the law is isotropic, so no material frame) -> S, updating the element's
    history row hist[e] (plastic strain, equivalent plastic strains). Returns (Sxx, Syy, Sxy, S33, d,
    equivalent plastic strain)."""
    lam = props[m, C12]
    g2 = props[m, C11] - lam  # 2 G
    kb = lam + g2 / 3.0  # bulk modulus
    exe = exx - hist[e, H_EPXX]
    eye = eyy - hist[e, H_EPYY]
    ezz = -hist[e, H_EPZZ]  # plane strain: the total E33 is zero
    exye = exy - hist[e, H_EPXY]
    tr = exe + eye + ezz
    sxx, syy, szz, sxy, syz, szx, dxx, dyy, dzz, dxy, dyz, dzx, dg = paraboloid_return(
        lam * tr + g2 * exe, lam * tr + g2 * eye, lam * tr + g2 * ezz, g2 * exye, 0.0, 0.0,
        0.5 * g2, kb, props[m, SIGU], props[m, SYCM], flow_alpha(props[m, NUP]))
    if dg > 0.0:
        hist[e, H_EPXX] += dxx
        hist[e, H_EPYY] += dyy
        hist[e, H_EPZZ] += dzz
        hist[e, H_EPXY] += dxy
        deq = equivalent_plastic_increment(dxx, dyy, dzz, dxy, dyz, dzx, props[m, NUP])
        hist[e, H_EQP] += deq
        if sxx + syy + szz > 0.0:  # flow under a tensile mean stress opens the crack band
            hist[e, H_EQPT] += deq
    d = min(1.0, math.sqrt(a0) * hist[e, H_EQPT] / props[m, UF])
    r = 1.0 - d
    return r * sxx, r * syy, r * sxy, r * szz, d, hist[e, H_EQP]


@numba.njit(cache=True, inline="always")
def strain_to_material_frame(c, s, exx, eyy, exy):
    """A tensor-shear strain (Exx, Eyy, Exy) in the material frame whose axis 1 is at angle phi (c = cos phi,
    s = sin phi) from x: E' = R E R^T. Returns (E11, E22, E12)."""
    e11 = c * c * exx + s * s * eyy + 2.0 * c * s * exy
    e22 = s * s * exx + c * c * eyy - 2.0 * c * s * exy
    e12 = -c * s * exx + c * s * eyy + (c * c - s * s) * exy
    return e11, e22, e12


@numba.njit(cache=True, inline="always")
def material_stress(props, m, cphi, sphi, exx, eyy, exy, ep_old, hist, e, a0, check):
    """Stress update at one integration point: Green-Lagrange E (global, tensor shear) -> S.

    A ``paraboloid`` matrix goes to :func:`paraboloid_matrix_stress`. Otherwise: rotates E into
    the material frame (cos/sin of the fibre angle), applies the plane-strain orthotropic stiffness
    with the fibre's 1D compressive plasticity (return mapping on S11 with linear hardening:
    Delta = (-S11_trial - sigma_yc - H |Ep|) / (C11 + H)), rotates S back. A ``brittle`` matrix with
    a crack band (props[m, CBAND] > 0) keeps in hist[e, H_KAPPA] the largest maximum principal
    stress its undamaged stress has reached and carries (1 - d) times that stress
    (:func:`crack_band_damage`, A0 the element's reference area); it fails when d reaches 1, not at
    sigma_u. ``hist`` is the (n, N_HIST) history of the elements (empty when no material keeps one).
    When ``check`` the failure criteria of the module docstring are evaluated.
    Returns (Sxx, Syy, Sxy, S33, Ep_new, failure mode).
    """
    kind = props[m, KIND]
    if kind == MATRIX_KIND and props[m, LAW] == LAW_PARABOLOID:
        sxx, syy, sxy, s33, d, eqp = paraboloid_matrix_stress(props, m, exx, eyy, exy, hist, e, a0)
        mode = 0
        if check:
            if d >= 1.0:
                mode = 4
            elif eqp >= props[m, EPSF]:
                mode = 12
        return sxx, syy, sxy, s33, ep_old, mode
    c, s = cphi, sphi
    e11, e22, e12 = strain_to_material_frame(c, s, exx, eyy, exy)
    k11 = props[m, C11]
    k12 = props[m, C12]
    k22 = props[m, C22]
    ep = ep_old
    s11 = k11 * (e11 - ep) + k12 * e22
    plastic = kind == FIBRE_KIND and props[m, PLASTIC] > 0.0
    if plastic:
        h = props[m, HARD]
        fy = -s11 - (props[m, SYC] + h * (-ep))
        if fy > 0.0:
            dl = fy / (k11 + h)
            ep = ep - dl
            s11 = k11 * (e11 - ep) + k12 * e22
    s22 = k12 * (e11 - ep) + k22 * e22
    s12 = 2.0 * props[m, C66] * e12
    s33 = props[m, C13] * (e11 - ep) + props[m, C23] * e22
    sxx = c * c * s11 + s * s * s22 - 2.0 * c * s * s12
    syy = s * s * s11 + c * c * s22 + 2.0 * c * s * s12
    sxy = c * s * s11 - c * s * s22 + (c * c - s * s) * s12
    band = kind == MATRIX_KIND and props[m, CBAND] > 0.0
    d = 0.0
    if band:
        s1 = 0.5 * (sxx + syy) + math.sqrt(0.25 * (sxx - syy) ** 2 + sxy * sxy)
        if s1 > hist[e, H_KAPPA]:
            hist[e, H_KAPPA] = s1
        d = crack_band_damage(hist[e, H_KAPPA], props[m, SIGU], props[m, CBAND], a0)
        sxx *= 1.0 - d
        syy *= 1.0 - d
        sxy *= 1.0 - d
        s33 *= 1.0 - d
    mode = 0
    if check:
        if kind == FIBRE_KIND:
            smax = 0.5 * (s11 + s22) + math.sqrt(0.25 * (s11 - s22) ** 2 + s12 * s12)
            if smax >= props[m, XT]:
                mode = 1
            elif not plastic and s11 <= -props[m, XC]:
                mode = 2
            elif math.sqrt(max(1.0 + 2.0 * e11, 0.0)) - 1.0 <= -props[m, EPSFC]:
                mode = 3
        elif kind == MATRIX_KIND:
            if band:
                if d >= 1.0:
                    mode = 4
            elif 0.5 * (s11 + s22) + math.sqrt(0.25 * (s11 - s22) ** 2 + s12 * s12) >= props[m, SIGU]:
                mode = 4
        else:
            sl = props[m, H_SL]
            st = props[m, H_ST]
            tau2 = (s12 / sl) ** 2
            if s11 >= 0.0:
                if (s11 / props[m, H_XT]) ** 2 + tau2 >= 1.0:
                    mode = 5
            elif (s11 / props[m, H_XC]) ** 2 >= 1.0:
                mode = 6
            if mode == 0:
                yc = props[m, H_YC]
                if s22 >= 0.0:
                    if (s22 / props[m, H_YT]) ** 2 + tau2 >= 1.0:
                        mode = 7
                elif (s22 / (2.0 * st)) ** 2 + ((yc / (2.0 * st)) ** 2 - 1.0) * s22 / yc + tau2 >= 1.0:
                    mode = 8
            if props[m, EHM_DELETE] == 0.0:
                mode = -mode  # overloaded, kept elastic
    return sxx, syy, sxy, s33, ep, mode
