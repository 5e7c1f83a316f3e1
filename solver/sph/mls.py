"""The pieces of the quadratic-complete surface gradient that the solid-SPH pair loops call.

The equations are those of :mod:`solver.sph.quadratic` (moving least squares with the complete
quadratic basis P(e) = (e_x, e_y, e_x^2, e_x e_y, e_y^2), e = (x_j - x_i) / h; Lancaster &
Salkauskas 1981, Math. Comp. 37:141; Belytschko, Krongauz, Organ, Fleming & Krysl 1996, CMAME
139:3): the sums of A_i and of the right-hand sides in the velocity-gradient pass
(:func:`accumulate`), the first two rows of A_i^-1 / h and the gradient from them
(:func:`quadratic_gradient`), and the transposed weights of the momentum pass
(:func:`transposed_weights`). They live apart from :mod:`solver.sph.quadratic` so that
:mod:`solver.sph.solid`'s loops, which run both forms, can use them without importing it.
"""

from __future__ import annotations

import numba
import numpy as np

#: columns of Q: flag (1 where the quadratic gradient is used), then C_i row x (5), row y (5)
NQ = 11
#: smallest pivot of A_i (scaled by its largest diagonal entry) for which the quadratic gradient is used
PIVOT_MIN = 1e-8
#: rows of a particle's scratch W of :func:`accumulate`: A_i (0-4, upper triangle), b_x (5), b_y (6), P (7)
W_ROWS = 8


@numba.njit(cache=True)
def solve_two_rows(A, out):
    """out[0:2, :] = the first two rows of A^-1 (A symmetric 5x5, destroyed): Gaussian elimination
    with partial pivoting on [A | e_1 e_2] (A^-1 symmetric, so its first rows are the solutions of
    A z = e_1, e_2). Returns False when a pivot falls below PIVOT_MIN x the largest diagonal entry."""
    n = 5
    R = np.zeros((n, 2))
    R[0, 0] = 1.0
    R[1, 1] = 1.0
    scale = 0.0
    for a in range(n):
        scale = max(scale, abs(A[a, a]))
    if scale <= 0.0:
        return False
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if abs(A[p, c]) < PIVOT_MIN * scale:
            return False
        if p != c:
            for b in range(n):
                A[c, b], A[p, b] = A[p, b], A[c, b]
            for b in range(2):
                R[c, b], R[p, b] = R[p, b], R[c, b]
        for r in range(c + 1, n):
            f = A[r, c] / A[c, c]
            if f != 0.0:
                for b in range(c, n):
                    A[r, b] -= f * A[c, b]
                for b in range(2):
                    R[r, b] -= f * R[c, b]
    for b in range(2):
        for c in range(n - 1, -1, -1):
            s = R[c, b]
            for d in range(c + 1, n):
                s -= A[c, d] * out[b, d]
            out[b, c] = s / A[c, c]
    return True


@numba.njit(cache=True, inline="always")
def accumulate(W, wv, ex, ey, dvx, dvy):
    """One neighbour's share of the moving-least-squares sums (:mod:`solver.sph.quadratic`):
    A_i += w P P^T (upper triangle, W[0:5]), b_x += w P (v_j - v_i)_x (W[5]), b_y alike (W[6]), with
    w = V_j omega_ij (``wv``), P = P(e), e = (ex, ey) = (x_j - x_i) / h; W[7] holds P."""
    p = W[7]
    p[0] = ex
    p[1] = ey
    p[2] = ex * ex
    p[3] = ex * ey
    p[4] = ey * ey
    for a in range(5):
        wa = wv * p[a]
        W[5, a] += wa * dvx
        W[6, a] += wa * dvy
        for b in range(a, 5):
            W[a, b] += wa * p[b]


@numba.njit(cache=True, inline="always")
def quadratic_gradient(W, Q, i, ih):
    """L_i = sum_j (v_j - v_i) (x) V_j omega_ij C_i P(e_ij) from the sums of :func:`accumulate`, with
    C_i = [I_2 0] A_i^-1 / h (:func:`solve_two_rows`; ``ih`` = 1 / h), written into Q[i] (flag 1, C_i).
    Returns (ok, dvx/dx, dvx/dy, dvy/dx, dvy/dy); ok False (Q[i] untouched) where A_i is singular."""
    Am = W[0:5]
    for a in range(5):
        for b in range(a):
            Am[a, b] = Am[b, a]
    C = np.zeros((2, 5))
    if not solve_two_rows(Am, C):
        return False, 0.0, 0.0, 0.0, 0.0
    gxx = 0.0  # d vx / dx
    gxy = 0.0
    gyx = 0.0
    gyy = 0.0
    for a in range(5):
        C[0, a] *= ih
        C[1, a] *= ih
        gxx += C[0, a] * W[5, a]
        gxy += C[1, a] * W[5, a]
        gyx += C[0, a] * W[6, a]
        gyy += C[1, a] * W[6, a]
        Q[i, 1 + a] = C[0, a]
        Q[i, 6 + a] = C[1, a]
    Q[i, 0] = 1.0
    return True, gxx, gxy, gyx, gyy


@numba.njit(cache=True, inline="always")
def transposed_weights(Q, iq, jq, qi, qj, wq, dx, dy, ih, rhoi, rhoj, bgxi, bgyi, bgxj, bgyj):
    """The stress terms' weights of a pair (i, j) of the momentum equation where i (``qi``) or j
    (``qj``) carries the quadratic-complete gradient (:mod:`solver.sph.quadratic`): the transpose of
    that gradient, (rho_i / rho_j) w' C_i P((x_j - x_i)/h) for i and -(rho_j / rho_i) w' C_j P((x_i - x_j)/h)
    for j, w' = ``wq`` = -h r W'(r); the other particle keeps its B grad_i W_ij (bgx*, bgy* as given).
    Q rows iq, jq; dx, dy = x_i - x_j. Returns (bgxi, bgyi, bgxj, bgyj)."""
    ex = dx * ih  # (x_i - x_j) / h; P((x_j - x_i)/h) flips the linear terms
    ey = dy * ih
    p2 = ex * ex
    p3 = ex * ey
    p4 = ey * ey
    if qi:
        s = wq * rhoi / rhoj
        bgxi = s * (-Q[iq, 1] * ex - Q[iq, 2] * ey + Q[iq, 3] * p2 + Q[iq, 4] * p3 + Q[iq, 5] * p4)
        bgyi = s * (-Q[iq, 6] * ex - Q[iq, 7] * ey + Q[iq, 8] * p2 + Q[iq, 9] * p3 + Q[iq, 10] * p4)
    if qj:
        s = -wq * rhoj / rhoi
        bgxj = s * (Q[jq, 1] * ex + Q[jq, 2] * ey + Q[jq, 3] * p2 + Q[jq, 4] * p3 + Q[jq, 5] * p4)
        bgyj = s * (Q[jq, 6] * ex + Q[jq, 7] * ey + Q[jq, 8] * p2 + Q[jq, 9] * p3 + Q[jq, 10] * p4)
    return bgxi, bgyi, bgxj, bgyj
