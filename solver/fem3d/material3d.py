"""Elastic laws of the 3D engine: isotropic and transversely isotropic (a fibre at any orientation).

Stress from strain in Voigt form, components ordered xx, yy, zz, xy, yz, zx. The engine is
total-Lagrangian (:mod:`.hex8`): the law maps the Green-Lagrange strain E (tensor shears E_xy,
...) to the 2nd Piola-Kirchhoff stress S (St. Venant-Kirchhoff, linear in E):

    S_a = sum_b C_ab Ehat_b,   Ehat = (E_xx, E_yy, E_zz, 2 E_xy, 2 E_yz, 2 E_zx)

with C the 6x6 stiffness in the engineering-shear convention (C_44 = G for an isotropic solid),
so C_ab = C_ijkl with a = (ij), b = (kl) the Voigt pairs above.

Isotropic: lambda = E nu / ((1 + nu)(1 - 2 nu)), mu = E / (2 (1 + nu)).

Transversely isotropic (axis 1 the fibre, 2-3 the isotropic plane), compliance in the fibre
frame (Jones, "Mechanics of Composite Materials", 2nd ed., 2.4): S11 = 1/E1, S22 = S33 = 1/E2,
S12 = S13 = -nu12/E1, S23 = -nu23/E2, shears 1/G12 (planes 1-2 and 3-1) and 1/G23 with
G23 = E2 / (2 (1 + nu23)); C = S^-1. A fibre along the unit vector d: C is rotated from the
fibre frame (axes d, e2, e3, any orthonormal completion: the 2-3 plane is isotropic) by the
tensor rule C'_ijkl = Q_ip Q_jq Q_kr Q_ls C_pqrs, Q = [d e2 e3] (columns).

Wave speeds: a plane wave along the unit vector n travels at v with rho v^2 an eigenvalue of the
Christoffel (acoustic) tensor Gamma_ik = C_ijkl n_j n_l (e.g. Auld, "Acoustic Fields and Waves in
Solids", 1973, ch. 7). The stiffest wave speed of a material (for the time step) is the largest
over directions, found on a dense sphere of directions plus the material's axes.

Set-up functions are numpy (run once); the stress kernel is compiled and works on scalars.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Voigt pairs, in the engine's order xx, yy, zz, xy, yz, zx
VOIGT = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0))


def isotropic_stiffness(E: float, nu: float) -> np.ndarray:
    """6x6 stiffness (engineering shears) of an isotropic solid."""
    if not (E > 0 and -1.0 < nu < 0.5):
        raise ValueError(f"E = {E}, nu = {nu}: need E > 0 and -1 < nu < 0.5")
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    C = np.zeros((6, 6))
    C[:3, :3] = lam
    C[[0, 1, 2], [0, 1, 2]] = lam + 2 * mu
    C[[3, 4, 5], [3, 4, 5]] = mu
    return C


def transversely_isotropic_stiffness(E1: float, E2: float, G12: float, nu12: float, nu23: float) -> np.ndarray:
    """6x6 stiffness in the fibre frame (axis 1 the fibre; module docstring)."""
    G23 = E2 / (2 * (1 + nu23))
    S = np.zeros((6, 6))
    S[0, 0] = 1 / E1
    S[1, 1] = S[2, 2] = 1 / E2
    S[0, 1] = S[1, 0] = S[0, 2] = S[2, 0] = -nu12 / E1
    S[1, 2] = S[2, 1] = -nu23 / E2
    S[3, 3] = 1 / G12  # xy = 1-2
    S[4, 4] = 1 / G23  # yz = 2-3
    S[5, 5] = 1 / G12  # zx = 3-1
    C = np.linalg.inv(S)
    if np.linalg.eigvalsh(0.5 * (C + C.T)).min() <= 0:
        raise ValueError(f"E1={E1}, E2={E2}, G12={G12}, nu12={nu12}, nu23={nu23}: not positive definite")
    return 0.5 * (C + C.T)


def to_tensor(C: np.ndarray) -> np.ndarray:
    """The 3x3x3x3 tensor C_ijkl of a 6x6 Voigt stiffness (engineering shears)."""
    T = np.zeros((3, 3, 3, 3))
    for a, (i, j) in enumerate(VOIGT):
        for b, (k, l) in enumerate(VOIGT):
            v = C[a, b]
            T[i, j, k, l] = T[j, i, k, l] = T[i, j, l, k] = T[j, i, l, k] = v
    return T


def to_voigt(T: np.ndarray) -> np.ndarray:
    C = np.zeros((6, 6))
    for a, (i, j) in enumerate(VOIGT):
        for b, (k, l) in enumerate(VOIGT):
            C[a, b] = T[i, j, k, l]
    return C


def rotate_stiffness(C: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """C'_ijkl = Q_ip Q_jq Q_kr Q_ls C_pqrs: the stiffness given in the frame whose axes are the columns of Q."""
    return to_voigt(np.einsum("ip,jq,kr,ls,pqrs->ijkl", Q, Q, Q, Q, to_tensor(C), optimize=True))


def fibre_frame(d) -> np.ndarray:
    """An orthonormal frame [d e2 e3] (columns) with d the unit fibre direction."""
    d = np.asarray(d, float)
    n = np.linalg.norm(d)
    if not n > 0:
        raise ValueError(f"fibre direction {d.tolist()}: must be non-zero")
    d = d / n
    a = np.eye(3)[int(np.argmin(np.abs(d)))]
    e2 = a - (a @ d) * d
    e2 /= np.linalg.norm(e2)
    return np.column_stack([d, e2, np.cross(d, e2)])


def fibre_stiffness(E1, E2, G12, nu12, nu23, direction) -> np.ndarray:
    """6x6 global stiffness of a transversely isotropic solid whose fibre points along ``direction``."""
    return rotate_stiffness(transversely_isotropic_stiffness(E1, E2, G12, nu12, nu23), fibre_frame(direction))


def fibre_direction(theta: float, psi: float = 0.0) -> np.ndarray:
    """Unit vector at in-plane angle ``theta`` from x (in x-y) tilted out of plane by ``psi`` [rad]."""
    return np.array([math.cos(theta) * math.cos(psi), math.sin(theta) * math.cos(psi), math.sin(psi)])


def christoffel(C: np.ndarray, n) -> np.ndarray:
    """Gamma_ik = C_ijkl n_j n_l for the unit vector n (or (m, 3) rows of them)."""
    n = np.asarray(n, float)
    return np.einsum("ijkl,...j,...l->...ik", to_tensor(C), n, n)


def wave_speeds(C: np.ndarray, rho: float, n) -> tuple[np.ndarray, np.ndarray]:
    """Plane-wave speeds along n, fastest first, and their polarizations (columns)."""
    n = np.asarray(n, float) / np.linalg.norm(n)
    w, v = np.linalg.eigh(christoffel(C, n))
    order = np.argsort(w)[::-1]
    return np.sqrt(w[order] / rho), v[:, order]


def _sphere(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    r = np.sqrt(1 - z * z)
    ph = math.pi * (3 - math.sqrt(5)) * k
    return np.column_stack([r * np.cos(ph), r * np.sin(ph), z])


def max_wave_speed(C: np.ndarray, rho: float, n_dirs: int = 4000) -> float:
    """The fastest plane-wave speed over all directions (sampled sphere + the stiffness's eigen-axes)."""
    dirs = [_sphere(n_dirs), np.eye(3)]
    # directions that maximise Gamma: the normal-stiffness block's eigenvectors (the fibre and its plane)
    _, v = np.linalg.eigh(C[:3, :3])
    dirs.append(v.T)
    T = to_tensor(C)
    n = np.vstack(dirs)
    n /= np.linalg.norm(n, axis=1)[:, None]
    G = np.einsum("ijkl,mj,ml->mik", T, n, n)
    w = np.linalg.eigvalsh(G).max(axis=1)
    # refine the best direction by a few local searches
    best = n[int(np.argmax(w))]
    wbest = float(w.max())
    step = 0.05
    rng = np.random.default_rng(0)
    for _ in range(60):
        cand = best + step * rng.standard_normal((24, 3))
        cand /= np.linalg.norm(cand, axis=1)[:, None]
        wc = np.linalg.eigvalsh(np.einsum("ijkl,mj,ml->mik", T, cand, cand)).max(axis=1)
        if wc.max() > wbest:
            wbest = float(wc.max())
            best = cand[int(np.argmax(wc))]
        else:
            step *= 0.7
    return math.sqrt(wbest / rho)


def compliance_in_frame(C: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The 6x6 compliance (engineering shears) expressed in the orthonormal frame whose axes are the rows of T."""
    return np.linalg.inv(rotate_stiffness(C, np.asarray(T).T))


@numba.njit(cache=True, inline="always")
def pk2_stress(C, m, exx, eyy, ezz, exy, eyz, ezx):
    """S = C : E for material row ``m`` of the (nm, 6, 6) stiffness table (tensor shears in, Voigt out)."""
    gxy = 2.0 * exy
    gyz = 2.0 * eyz
    gzx = 2.0 * ezx
    s0 = C[m, 0, 0] * exx + C[m, 0, 1] * eyy + C[m, 0, 2] * ezz + C[m, 0, 3] * gxy + C[m, 0, 4] * gyz + C[m, 0, 5] * gzx
    s1 = C[m, 1, 0] * exx + C[m, 1, 1] * eyy + C[m, 1, 2] * ezz + C[m, 1, 3] * gxy + C[m, 1, 4] * gyz + C[m, 1, 5] * gzx
    s2 = C[m, 2, 0] * exx + C[m, 2, 1] * eyy + C[m, 2, 2] * ezz + C[m, 2, 3] * gxy + C[m, 2, 4] * gyz + C[m, 2, 5] * gzx
    s3 = C[m, 3, 0] * exx + C[m, 3, 1] * eyy + C[m, 3, 2] * ezz + C[m, 3, 3] * gxy + C[m, 3, 4] * gyz + C[m, 3, 5] * gzx
    s4 = C[m, 4, 0] * exx + C[m, 4, 1] * eyy + C[m, 4, 2] * ezz + C[m, 4, 3] * gxy + C[m, 4, 4] * gyz + C[m, 4, 5] * gzx
    s5 = C[m, 5, 0] * exx + C[m, 5, 1] * eyy + C[m, 5, 2] * ezz + C[m, 5, 3] * gxy + C[m, 5, 4] * gyz + C[m, 5, 5] * gzx
    return s0, s1, s2, s3, s4, s5


@numba.njit(cache=True)
def stress_from_strain(C, m, E):
    """Compiled array form of :func:`pk2_stress`: E (6,) tensor shears -> S (6,)."""
    s = pk2_stress(C, m, E[0], E[1], E[2], E[3], E[4], E[5])
    out = np.empty(6)
    for k in range(6):
        out[k] = s[k]
    return out
