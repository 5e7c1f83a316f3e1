"""The accumulators of the symmetric SPH pair loops (the 2D momentum pass of :mod:`solver.sph.solid`, both
pair passes of :mod:`solver.sph3d.solid`).

Each pair is visited once, by the particle k that comes first in the cell order: k's running sum gains
m_j X_ij, its partner l gains m_i X_ji (X_ji = X_ij for even terms, -X_ij for odd ones: the momentum
equation's pair force, Gray, Monaghan & Swift 2001 eq. 1, is antisymmetric, so momentum is conserved
to round-off). The particles are split into contiguous chunks of the cell order; chunk t adds into its
own accumulator A[t] (rows from its first particle on: partners come later in cell order), so threads
never write to the same memory, and a second pass sums the chunks in the fixed order t = 0, 1, ...:
the result does not depend on how many threads run.
"""

from __future__ import annotations

import numba


@numba.njit(cache=True, inline="always")
def chunk_rows(t, n, n_chunks):
    """The cell-order rows k0 <= k < k1 of chunk t of n_chunks: the particles whose pairs it visits. Its
    accumulator A[t] receives shares on every row from k0 on (partners come later in cell order)."""
    return t * n // n_chunks, (t + 1) * n // n_chunks


@numba.njit(cache=True, inline="always")
def clear_rows(A, t, k0, n, nq):
    """Zero columns 0 .. nq - 1 of the rows k0 .. n - 1 of chunk t's accumulator (all it can reach)."""
    for k in range(k0, n):
        for q in range(nq):
            A[t, k, q] = 0.0


@numba.njit(cache=True, inline="always")
def share_pair(own, A, t, l, q0, X, m_own, m_partner):
    """Both shares of one pair's terms X (a tuple) in the columns q0, q0 + 1, ...: particle k's running sum
    ``own`` gains m_own X, its partner l gains m_partner X in chunk t's accumulator. Each pair is visited
    once: for the sums sum_j m_j X_ij, m_own = m_j and m_partner = m_i where X_ji = X_ij (even terms),
    -m_i where X_ji = -X_ij (odd terms)."""
    for q in range(len(X)):
        own[q0 + q] += m_own * X[q]
        A[t, l, q0 + q] += m_partner * X[q]


@numba.njit(cache=True, inline="always")
def close_row(A, t, k, own):
    """Add particle k's own sum to what it received as a partner of the rows before it (chunk t's
    accumulator) and clear the sum for the next row."""
    for q in range(own.shape[0]):
        A[t, k, q] += own[q]
        own[q] = 0.0


@numba.njit(cache=True, inline="always")
def sum_chunks(A, k, n, nq):
    """Row k of the chunk accumulators summed into A[0, k, 0 .. nq - 1] in the fixed order t = 0, 1, ...
    over the chunks that reach it (chunk t from its first row on), so the sum does not depend on the
    thread count. Returns the number of those chunks."""
    n_chunks = A.shape[0]
    nt = 1
    while nt < n_chunks and nt * n // n_chunks <= k:
        for q in range(nq):
            A[0, k, q] += A[nt, k, q]
        nt += 1
    return nt
