"""The 4-node quadrilateral: one-point integration, total-Lagrangian, assumed-strain hourglass.

Kinematics (total-Lagrangian, plane strain, unit width). With the mean shape-function
gradients of the reference quad (Flanagan & Belytschko 1981, IJNME 17:679, eq. 15)

    b_x = [Y1-Y3, Y2-Y0, Y3-Y1, Y0-Y2] / (2 A0),  b_y = [X3-X1, X0-X2, X1-X3, X2-X0] / (2 A0),

the deformation gradient is F_ij = sum_I x_iI b_jI, the Green-Lagrange strain
E = (F^T F - I) / 2, the 2nd Piola-Kirchhoff stress S = S(E) (:mod:`.materials`), the first
Piola-Kirchhoff P = F S and the internal nodal force f_iI = A0 P_ij b_jI.

Hourglass control by physical (assumed-strain) stabilization, after Belytschko & Bindeman
1993 (CMAME 105:225) and Belytschko & Bachrach 1986 (CMAME 54:279): the hourglass amplitude
q = sum_I gamma_I x_I with gamma_I = (h_I - (h.X) b_xI - (h.Y) b_yI) / 4, h = (1,-1,1,-1)
(zero for every affine motion of the reference quad), is rotated back into the reference
frame by the element's polar rotation R (F = R U) and split along the element's axes
t1 = unit(dX/dxi) and t2 = t1 rotated by 90 deg. A mode u1 = q1 xi eta is the exact
pure-bending mode of a rectangle 2a x 2b: its strain e11 = q1 eta / a, with the parasitic
shear dropped and the transverse stress free, stores

    W = (1/2) K1 q1^2,  K1 = E1' A0 / (3 a^2),  K2 = E2' A0 / (3 b^2)  (b = A0 / (4 a)),

with E1', E2' the plane-strain uniaxial moduli of the element's material along t1, t2
(:func:`.materials.uniaxial_moduli`). The one-point part does not see these modes, so a
beam bends with its exact Euler-Bernoulli stiffness even with one element across; no
shear locking, no tuning coefficient. The hourglass force is f_I = gamma_I R (K1 q1 t1 +
K2 q2 t2) and the hourglass energy is the work these forces do (W without rotation).

With ``physics.hourglass_follows_material`` an inelastic element's K1, K2 are scaled by the smallest secant
ratio |S| / |C : E| its centre has had (:func:`hourglass_scale`), as the 3D hexahedron's are
(:func:`solver.fem3d.hex8.hourglass_scale`), but never below :data:`HOURGLASS_SECANT_FLOOR` of the elastic
stiffness: a fibre flowing at Xc or a softening matrix element resists bending little more than its material
does, and keeps enough hourglass control for its section to stay plane. Without the floor the flowing
compression side of a bent fibre loses its control and ``fibrecut verify fibre-bending
--set hourglass_follows_material=1`` fails (docs/numerics.md, "The 2D quad's hourglass in inelastic
elements"). Off (the default), the modes keep the elastic stiffness whatever the centre does.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .materials import (C11, C12, C13, C22, C23, C66, CBAND, CMAX, FIBRE_KIND, KIND, LAW, LAW_PARABOLOID, MATRIX_KIND,
                        PLASTIC, XT, material_stress, strain_to_material_frame, uniaxial_moduli)



def reference_geometry(X, Y, quads):
    """Vectorised reference quantities: area A0 [m^2 per m], axis angle beta of t1, a, b."""
    x = X[quads]
    y = Y[quads]
    a0 = 0.5 * ((x[:, 2] - x[:, 0]) * (y[:, 3] - y[:, 1]) - (x[:, 3] - x[:, 1]) * (y[:, 2] - y[:, 0]))
    gx = 0.25 * (-x[:, 0] + x[:, 1] + x[:, 2] - x[:, 3])
    gy = 0.25 * (-y[:, 0] + y[:, 1] + y[:, 2] - y[:, 3])
    a = np.hypot(gx, gy)
    beta = np.arctan2(gy, gx)
    b = a0 / (4.0 * np.maximum(a, 1e-300))
    return a0, beta, a, b


def hourglass_stiffness(X, Y, quads, mat, phi, props):
    """(n, 2) stiffnesses K1, K2 of the assumed-strain hourglass modes (module docstring)."""
    a0, beta, a, b = reference_geometry(X, Y, quads)
    e1, e2 = uniaxial_moduli(props, mat, phi, beta)
    k = np.empty((quads.shape[0], 2))
    k[:, 0] = e1 * a0 / (3.0 * a * a)
    k[:, 1] = e2 * a0 / (3.0 * b * b)
    return k


HOURGLASS_SECANT_FLOOR = 0.5
"""The smallest factor on an inelastic element's hourglass stiffness when it follows the material (our choice,
verified by ``fibrecut verify fibre-bending --set hourglass_follows_material=1``, failure curvature against beam
theory: 0.5 passes with 3, 4, 5 and 6 elements across a fibre; 0.25 fails with 6 (the hourglass guard in an end
cap) and 0 with 3; docs/numerics.md)."""


@numba.njit(cache=True, inline="always")
def inelastic(props, m):
    """True for a material whose stress can fall below the elastic one: a fibre with compressive plasticity, a
    ``paraboloid`` matrix, a brittle matrix with a crack band (:mod:`.materials`); the EHM stays elastic."""
    kind = props[m, KIND]
    if kind == FIBRE_KIND:
        return props[m, PLASTIC] > 0.0
    if kind == MATRIX_KIND:
        return props[m, LAW] == LAW_PARABOLOID or props[m, CBAND] > 0.0
    return False


@numba.njit(cache=True, inline="always")
def hourglass_scale(props, m, cphi, sphi, exx, eyy, exy, sxx, syy, sxy, s33):
    """The secant ratio s = |S| / |C : E| of an element's centre (Frobenius norms with the out-of-plane
    stress, tensor shears; C the material's elastic plane-strain stiffness in its frame, E the total
    Green-Lagrange strain): 1 while the centre is elastic, below 1 once it has flowed or softened, 1 for a
    strain below 1e-9. The 2D form of :func:`solver.fem3d.hex8.hourglass_scale`, whose docstring gives the
    reasons (our choice, after Belytschko & Bindeman 1993, whose stiffness is the material's)."""
    e11, e22, e12 = strain_to_material_frame(cphi, sphi, exx, eyy, exy)
    if e11 * e11 + e22 * e22 + 2.0 * e12 * e12 < 1e-18:
        return 1.0
    t11 = props[m, C11] * e11 + props[m, C12] * e22
    t22 = props[m, C12] * e11 + props[m, C22] * e22
    t12 = 2.0 * props[m, C66] * e12
    t33 = props[m, C13] * e11 + props[m, C23] * e22
    trial = t11 * t11 + t22 * t22 + 2.0 * t12 * t12 + t33 * t33
    if trial <= 0.0:
        return 1.0
    r = math.sqrt((sxx * sxx + syy * syy + 2.0 * sxy * sxy + s33 * s33) / trial)
    return r if r < 1.0 else 1.0


@numba.njit(cache=True, inline="always")
def quad_update(e, quads, X0, Y0, px, py, mat, cphi, sphi, khg, props, stress, strain, eplast, mhist, hgd, eint, ehg, hq,
                fe, check, edge_check=False):
    """One element's stress update and nodal forces at the current positions.

    Writes the 8 nodal forces (x0, y0, x1, y1, ...; force ON the nodes = minus the internal
    force) into fe[e], the stress (Sxx, Syy, Sxy, S33; 2nd Piola-Kirchhoff) into stress[e],
    the strain (Exx, Eyy, Exy) into strain[e], the fibre plastic strain into eplast[e],
    adds the stress work A0 (S_old + S_new)/2 : (E_new - E_old) to eint[e] (trapezoidal in
    strain, work-conjugate pair S, E) and the hourglass work (G_old + G_new)/2 . (q_new - q_old)
    to ehg[e] (G = R (K1 q1 t1 + K2 q2 t2) the generalised hourglass force, hq[e] = (q, G) of
    the last step): the work the hourglass forces really did, equal to (1/2) K q^2 without
    rotation.
    mhist[e] is the element's history row (matrix plasticity and crack band, :func:`.materials.material_stress`);
    ``mhist`` has no rows when no material keeps a history. hgd[e] is 1 - the smallest secant ratio the
    element's centre has had (:func:`hourglass_scale`; non-decreasing, as a damage variable: the force
    s K q with s never rising cannot give back more work than it took), and K1, K2 are scaled by
    max(1 - hgd[e], :data:`HOURGLASS_SECANT_FLOOR`) (still never rising);
    ``hgd`` has no rows when the hourglass keeps the elastic stiffness (``physics.hourglass_follows_material``
    off).
    With ``check`` and ``edge_check`` a fibre element's tensile criterion is also evaluated at its
    edge fibres: the assumed-strain bending modes carry the strains e11 = q1 eta / a and
    e22 = q2 xi / b, so at the element's edge the stress along t1 exceeds the centre's by
    E1' |q1| / a = 3 a K1 |q1| / A0 (along t2: 3 b K2 |q2| / A0); projected on the fibre axis and
    added to the centre's S11, the maximum principal stress there is checked against Xt (mode 1).
    A fibre bent with two or three elements across reaches Xt at its surface, where the centre of
    its outer element sees a half or two thirds of it.
    Returns (critical time step of the element at CFL 1 [s], failure mode, inverted flag):
    dt_e = A / (d_max c_max) with A the current area, d_max the longer current diagonal and
    c_max the material's fastest wave speed (exact for the square's breathing mode).
    """
    n0 = quads[e, 0]
    n1 = quads[e, 1]
    n2 = quads[e, 2]
    n3 = quads[e, 3]
    X0_, X1_, X2_, X3_ = X0[n0], X0[n1], X0[n2], X0[n3]
    Y0_, Y1_, Y2_, Y3_ = Y0[n0], Y0[n1], Y0[n2], Y0[n3]
    x0, x1, x2, x3 = px[n0], px[n1], px[n2], px[n3]
    y0, y1, y2, y3 = py[n0], py[n1], py[n2], py[n3]
    a0 = 0.5 * ((X2_ - X0_) * (Y3_ - Y1_) - (X3_ - X1_) * (Y2_ - Y0_))
    inv = 0.5 / a0
    bx0 = (Y1_ - Y3_) * inv
    bx1 = (Y2_ - Y0_) * inv
    bx2 = (Y3_ - Y1_) * inv
    bx3 = (Y0_ - Y2_) * inv
    by0 = (X3_ - X1_) * inv
    by1 = (X0_ - X2_) * inv
    by2 = (X1_ - X3_) * inv
    by3 = (X2_ - X0_) * inv
    f00 = x0 * bx0 + x1 * bx1 + x2 * bx2 + x3 * bx3
    f01 = x0 * by0 + x1 * by1 + x2 * by2 + x3 * by3
    f10 = y0 * bx0 + y1 * bx1 + y2 * bx2 + y3 * bx3
    f11 = y0 * by0 + y1 * by1 + y2 * by2 + y3 * by3
    jac = f00 * f11 - f01 * f10
    exx = 0.5 * (f00 * f00 + f10 * f10 - 1.0)
    eyy = 0.5 * (f01 * f01 + f11 * f11 - 1.0)
    exy = 0.5 * (f00 * f01 + f10 * f11)
    m = mat[e]
    sxx, syy, sxy, s33, ep, mode = material_stress(props, m, cphi[e], sphi[e], exx, eyy, exy, eplast[e], mhist, e, a0,
                                                   check)
    # stress work (trapezoidal), then store the new state
    eint[e] += a0 * (0.5 * (stress[e, 0] + sxx) * (exx - strain[e, 0]) + 0.5 * (stress[e, 1] + syy) * (eyy - strain[e, 1])
                     + (stress[e, 2] + sxy) * (exy - strain[e, 2]))
    stress[e, 0] = sxx
    stress[e, 1] = syy
    stress[e, 2] = sxy
    stress[e, 3] = s33
    strain[e, 0] = exx
    strain[e, 1] = eyy
    strain[e, 2] = exy
    eplast[e] = ep
    hs = 1.0  # the hourglass stiffness's factor
    if hgd.shape[0] > 0 and inelastic(props, m):
        d_hg = 1.0 - hourglass_scale(props, m, cphi[e], sphi[e], exx, eyy, exy, sxx, syy, sxy, s33)
        if d_hg > hgd[e]:
            hgd[e] = d_hg
        hs = max(1.0 - hgd[e], HOURGLASS_SECANT_FLOOR)
    # first Piola-Kirchhoff P = F S, times the reference area
    p00 = a0 * (f00 * sxx + f01 * sxy)
    p01 = a0 * (f00 * sxy + f01 * syy)
    p10 = a0 * (f10 * sxx + f11 * sxy)
    p11 = a0 * (f10 * sxy + f11 * syy)
    # hourglass: gamma from the reference, amplitude from the current positions
    hx = X0_ - X1_ + X2_ - X3_
    hy = Y0_ - Y1_ + Y2_ - Y3_
    g0 = 0.25 * (1.0 - hx * bx0 - hy * by0)
    g1 = 0.25 * (-1.0 - hx * bx1 - hy * by1)
    g2 = 0.25 * (1.0 - hx * bx2 - hy * by2)
    g3 = 0.25 * (-1.0 - hx * bx3 - hy * by3)
    qx = g0 * x0 + g1 * x1 + g2 * x2 + g3 * x3
    qy = g0 * y0 + g1 * y1 + g2 * y2 + g3 * y3
    rn = math.sqrt((f00 + f11) ** 2 + (f10 - f01) ** 2)
    rc = 1.0
    rs = 0.0
    if rn > 0.0:
        rc = (f00 + f11) / rn
        rs = (f10 - f01) / rn
    qlx = rc * qx + rs * qy  # R^T q
    qly = -rs * qx + rc * qy
    tx = 0.25 * (-X0_ + X1_ + X2_ - X3_)
    ty = 0.25 * (-Y0_ + Y1_ + Y2_ - Y3_)
    tn = math.sqrt(tx * tx + ty * ty)
    tx /= tn
    ty /= tn
    q1 = tx * qlx + ty * qly
    q2 = -ty * qlx + tx * qly
    k1 = hs * khg[e, 0]
    k2 = hs * khg[e, 1]
    glx = k1 * q1 * tx - k2 * q2 * ty  # K1 q1 t1 + K2 q2 t2 (reference frame)
    gly = k1 * q1 * ty + k2 * q2 * tx
    gx = rc * glx - rs * gly  # rotate to the current frame: R g
    gy = rs * glx + rc * gly
    if check and edge_check and mode == 0 and props[m, KIND] == FIBRE_KIND:
        # the tensile criterion at the edge fibres (docstring): centre stress + bending stress
        ds1 = 3.0 * tn * k1 * abs(q1) / a0
        ds2 = 0.75 * a0 / tn * k2 * abs(q2) / a0  # 3 b K2 |q2| / A0 with b = A0 / (4 a)
        c = cphi[e]
        s = sphi[e]
        ca = c * tx + s * ty  # cosine of the angle between the fibre and t1
        s11 = c * c * sxx + s * s * syy + 2.0 * c * s * sxy + ca * ca * ds1 + (1.0 - ca * ca) * ds2
        s22 = s * s * sxx + c * c * syy - 2.0 * c * s * sxy
        s12 = -c * s * sxx + c * s * syy + (c * c - s * s) * sxy
        if 0.5 * (s11 + s22) + math.sqrt(0.25 * (s11 - s22) ** 2 + s12 * s12) >= props[m, XT]:
            mode = 1
    ehg[e] += 0.5 * ((hq[e, 2] + gx) * (qx - hq[e, 0]) + (hq[e, 3] + gy) * (qy - hq[e, 1]))
    hq[e, 0] = qx
    hq[e, 1] = qy
    hq[e, 2] = gx
    hq[e, 3] = gy
    fe[e, 0] = -(p00 * bx0 + p01 * by0 + g0 * gx)
    fe[e, 1] = -(p10 * bx0 + p11 * by0 + g0 * gy)
    fe[e, 2] = -(p00 * bx1 + p01 * by1 + g1 * gx)
    fe[e, 3] = -(p10 * bx1 + p11 * by1 + g1 * gy)
    fe[e, 4] = -(p00 * bx2 + p01 * by2 + g2 * gx)
    fe[e, 5] = -(p10 * bx2 + p11 * by2 + g2 * gy)
    fe[e, 6] = -(p00 * bx3 + p01 * by3 + g3 * gx)
    fe[e, 7] = -(p10 * bx3 + p11 * by3 + g3 * gy)
    # current area and diagonals -> critical step
    ac = 0.5 * ((x2 - x0) * (y3 - y1) - (x3 - x1) * (y2 - y0))
    d1 = (x2 - x0) ** 2 + (y2 - y0) ** 2
    d2 = (x3 - x1) ** 2 + (y3 - y1) ** 2
    inverted = 0
    if ac <= 0.0 or jac <= 0.0:
        inverted = 1
        dte = 0.0
    else:
        dte = ac / (math.sqrt(max(d1, d2)) * props[m, CMAX])
    return dte, mode, inverted
