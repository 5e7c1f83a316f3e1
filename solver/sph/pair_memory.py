"""The particles' memory of their contact pairs with the finite elements' boundary (2D edges, 3D faces).

A particle's column of ``pairs`` holds in row 0 the compression it carries (the largest of its pairs'
at the last step, which a new pair may start with) and then one slot of ``stride`` rows per
remembered pair: the boundary piece's key (0: the slot is empty), the pair's offset d0, its
compression c and, where the law has more state, the rest (the 2D springs' held force). A pair's
spring holds k c^2 / 2; a pair that is forgotten (its piece gone, out of the cells searched, no slot
left, or the particle moved out of an element) takes that energy with it, and the coupling books it.
The laws that fill the slots: :func:`solver.sph.coupling.particle_edge_contact` (2D, 4 rows a slot)
and :func:`solver.hybrid.faces3d.particle_faces` (3D, 3 rows a slot).
"""

from __future__ import annotations

import numba
import numpy as np

#: a boundary piece's key: a * KEY_BASE + b + 1 for its node pair (a, b), exact in float64 below 2^26 nodes
KEY_BASE = 67108864.0


def new_pair_memory(n: int, npair: int, stride: int) -> np.ndarray:
    """The pair memory of n particles with npair slots of ``stride`` rows, all empty."""
    return np.zeros((1 + stride * npair, n))


@numba.njit(cache=True, inline="always")
def find_slot(pairs, p, stride, npair, key):
    """The slot of particle p that remembers ``key``, or -1."""
    for j in range(npair):
        if pairs[1 + stride * j, p] == key:
            return j
    return -1


@numba.njit(cache=True, inline="always")
def store_slots(pairs, p, stride, npair, seen, new, n_new, half_k, out, o):
    """Particle p's slots after a step: the pairs not ``seen`` in it are forgotten (their k c^2 / 2 into
    out[o]), the n_new pairs kept (``new[r, j]``: row r of slot j, key first) written, the rest emptied."""
    for j in range(npair):
        if pairs[1 + stride * j, p] != 0.0 and not seen[j]:
            c = pairs[3 + stride * j, p]
            out[o] += half_k * c * c
    for j in range(npair):
        for r in range(stride):
            pairs[1 + stride * j + r, p] = new[r, j] if j < n_new else 0.0


@numba.njit(cache=True, inline="always")
def forget_all(pairs, p, stride, npair, half_k, out, o):
    """Particle p forgets every pair (it was moved): their k c^2 / 2 into out[o], its column emptied."""
    for j in range(npair):
        c = pairs[3 + stride * j, p]
        out[o] += half_k * c * c
    for r in range(pairs.shape[0]):
        pairs[r, p] = 0.0


def spring_energy(pairs: np.ndarray, k: float, stride: int) -> float:
    """E_s: the energy the springs of the pair memory hold, k c^2 / 2 summed over every slot's c."""
    c = pairs[3::stride]
    return 0.5 * k * float(np.sum(c * c))
