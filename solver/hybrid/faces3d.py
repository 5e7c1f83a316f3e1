"""Particles against the boundary faces of the surviving hexahedra: the 3D hybrid's particle-element contact.

The 3D form of the 2D hybrid's particle-edge springs (:mod:`solver.sph.coupling`), node-to-face as the 3D
engine's fragment contact (:func:`solver.fem3d.contact3d.fragment_contact3d`; Belytschko, Liu & Moran 2014,
sec. 10.4, penalty form), with the particle as the node. Each boundary face (its four nodes counter-
clockwise seen from outside, :func:`solver.fem3d.contact3d.boundary_faces`) is split into the triangles
(0, 1, 2) and (0, 2, 3) with the outward unit normal n. A particle at p with gap g = (p - x_a) . n to a
triangle whose plane it projects into (barycentric weights w_a, w_b, w_c >= 0) is in contact when
-d_max < g < r_c: in front of the face closer than the contact radius r_c, or behind it by less than
d_max (half the thinnest element: a particle that far into an element is pushed out by the nearest faces
only). Every such face pushes, each with its own spring (a particle in a closing gap or in a concave
corner feels both sides; the two triangles of one face count once), so the force is continuous as a
particle crosses a face's plane. A projection counts as inside a triangle up to W_TOL outside in its
barycentric weights (on a warped face a point on the diagonal projects a little outside both triangles). With the overlap d = r_c - g > 0 each pair spring

    f_p = k d n                      on the particle
    f_j = -w_j k d n                 on the triangle's nodes j = a, b, c (action = reaction)

stores E_s = k d^2 / 2 (k: the pair penalty PAIR_ALPHA m_min / dt^2 of :func:`solver.contact.contact_stiffness`).
The forces sum to zero (momentum is exchanged, not made); as in the fragment contact the normal's
dependence on the nodes is left out of the nodal forces (a moment of order d / face size).

The faces are binned, every evaluation, in a grid of cubic cells over the particles' bounding box
(:func:`bin_boxes`: each face in every cell its bounding box grown by the search pad overlaps; faces
outside the grid are left out). :func:`inside_living` counts particles inside a living hexahedron (behind
all six of its face planes), the check that particles do not stay inside intact elements.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: the six faces of a hexahedron (:mod:`solver.fem3d.hex8` numbering), counter-clockwise seen from outside
from ..fem3d.contact3d import HEX_FACES

#: the grid's largest number of cells; a coarser cell when the particles spread farther
MAX_CELLS = 1 << 18
#: how far outside a triangle (in barycentric weight) a projection still counts as inside: on a warped face
#: a point on the diagonal projects a little outside both triangles, and would fall through the face
W_TOL = 1e-2


def grid_for(px: np.ndarray, cell: float, margin: float) -> np.ndarray:
    """[x0, y0, z0, cell, nx, ny, nz] of a grid over the points px (3, n) grown by ``margin``, cells of at
    least ``cell`` and at most MAX_CELLS of them."""
    lo = px.min(axis=1) - margin
    hi = px.max(axis=1) + margin
    cell = float(cell)
    while np.prod(np.floor((hi - lo) / cell) + 1) > MAX_CELLS:
        cell *= 1.5
    n = np.floor((hi - lo) / cell) + 1
    return np.array([lo[0], lo[1], lo[2], cell, n[0], n[1], n[2]])


@numba.njit(cache=True, inline="always")
def _cell(p, lo, cell, n):
    i = int((p - lo) / cell)
    return min(max(i, 0), n - 1)


@numba.njit(cache=True)
def bin_boxes(x, items, ncol, grid, pad):
    """CSR (start (ncells + 1), entries) of the items (rows of node ids, the first ``ncol`` columns) per
    cell of ``grid`` ([x0, y0, z0, cell, nx, ny, nz]): an item in every cell its bounding box grown by
    ``pad`` overlaps; items wholly outside the grid are left out."""
    cell = grid[3]
    nx, ny, nz = int(grid[4]), int(grid[5]), int(grid[6])
    hx = grid[0] + nx * cell
    hy = grid[1] + ny * cell
    hz = grid[2] + nz * cell
    start = np.zeros(nx * ny * nz + 1, np.int64)
    ent = np.zeros(0, np.int64)
    for rnd in range(2):
        for e in range(items.shape[0]):
            lx = ly = lz = 1e300
            ux = uy = uz = -1e300
            for k in range(ncol):
                nd = items[e, k]
                lx = min(lx, x[0, nd])
                ux = max(ux, x[0, nd])
                ly = min(ly, x[1, nd])
                uy = max(uy, x[1, nd])
                lz = min(lz, x[2, nd])
                uz = max(uz, x[2, nd])
            if (ux + pad < grid[0] or lx - pad > hx or uy + pad < grid[1] or ly - pad > hy or uz + pad < grid[2]
                    or lz - pad > hz):
                continue
            i0, i1 = _cell(lx - pad, grid[0], cell, nx), _cell(ux + pad, grid[0], cell, nx)
            j0, j1 = _cell(ly - pad, grid[1], cell, ny), _cell(uy + pad, grid[1], cell, ny)
            k0, k1 = _cell(lz - pad, grid[2], cell, nz), _cell(uz + pad, grid[2], cell, nz)
            for kk in range(k0, k1 + 1):
                for jj in range(j0, j1 + 1):
                    for ii in range(i0, i1 + 1):
                        c = (kk * ny + jj) * nx + ii
                        if rnd == 0:
                            start[c + 1] += 1
                        else:
                            ent[start[c]] = e
                            start[c] += 1
        if rnd == 0:
            for c in range(1, start.shape[0]):
                start[c] += start[c - 1]
            ent = np.empty(start[start.shape[0] - 1], np.int64)
    for c in range(start.shape[0] - 1, 0, -1):
        start[c] = start[c - 1]
    start[0] = 0
    return start, ent


@numba.njit(cache=True, inline="always")
def _spring(p, g, nx_, ny_, nz_, wa, wb, wc, a, b, cc, k, r_c, fp, fn, out):
    """The pair spring of overlap d = r_c - g along n on particle p, its reaction on the nodes a, b, cc."""
    d = r_c - g
    f = k * d
    fx, fy, fz = f * nx_, f * ny_, f * nz_
    fp[0, p] += fx
    fp[1, p] += fy
    fp[2, p] += fz
    fn[0, a] -= wa * fx
    fn[1, a] -= wa * fy
    fn[2, a] -= wa * fz
    fn[0, b] -= wb * fx
    fn[1, b] -= wb * fy
    fn[2, b] -= wb * fz
    fn[0, cc] -= wc * fx
    fn[1, cc] -= wc * fy
    fn[2, cc] -= wc * fz
    out[0] += 0.5 * k * d * d
    if d > out[2]:
        out[2] = d


@numba.njit(cache=True)
def particle_faces(px, x, faces, grid, k, r_c, d_max, fp, fn, out):
    """The pair springs of the particles px (3, np) against the faces (nf, >= 4 node ids) at the node
    positions x (module docstring): forces on the particles into fp (3, np) and on the nodes into fn
    (3, nn), both overwritten. out = [spring energy E_s [J], particles in contact, deepest overlap d,
    particles behind a face (g < 0)]."""
    for c in range(3):
        for i in range(fp.shape[1]):
            fp[c, i] = 0.0
        for i in range(fn.shape[1]):
            fn[c, i] = 0.0
    for j in range(out.shape[0]):
        out[j] = 0.0
    if faces.shape[0] == 0 or px.shape[1] == 0:
        return
    start, ent = bin_boxes(x, faces, 4, grid, r_c + d_max)
    cell = grid[3]
    nx, ny, nz = int(grid[4]), int(grid[5]), int(grid[6])
    for p in range(px.shape[1]):
        qx, qy, qz = px[0, p], px[1, p], px[2, p]
        c = (_cell(qz, grid[2], cell, nz) * ny + _cell(qy, grid[1], cell, ny)) * nx + _cell(qx, grid[0], cell, nx)
        n_in = 0
        behind = False
        for m in range(start[c], start[c + 1]):
            e = ent[m]
            for t in range(2):
                a = faces[e, 0]
                b = faces[e, 1 + t]
                cc = faces[e, 2 + t]
                e1x, e1y, e1z = x[0, b] - x[0, a], x[1, b] - x[1, a], x[2, b] - x[2, a]
                e2x, e2y, e2z = x[0, cc] - x[0, a], x[1, cc] - x[1, a], x[2, cc] - x[2, a]
                nx_ = e1y * e2z - e1z * e2y
                ny_ = e1z * e2x - e1x * e2z
                nz_ = e1x * e2y - e1y * e2x
                a2 = math.sqrt(nx_ * nx_ + ny_ * ny_ + nz_ * nz_)
                if a2 <= 0.0:
                    continue
                nx_ /= a2
                ny_ /= a2
                nz_ /= a2
                dx, dy, dz = qx - x[0, a], qy - x[1, a], qz - x[2, a]
                g = dx * nx_ + dy * ny_ + dz * nz_
                if g >= r_c or g <= -d_max:
                    continue
                sx, sy, sz = dx - g * nx_, dy - g * ny_, dz - g * nz_
                d00 = e1x * e1x + e1y * e1y + e1z * e1z
                d01 = e1x * e2x + e1y * e2y + e1z * e2z
                d11 = e2x * e2x + e2y * e2y + e2z * e2z
                d20 = sx * e1x + sy * e1y + sz * e1z
                d21 = sx * e2x + sy * e2y + sz * e2z
                den = d00 * d11 - d01 * d01
                if den <= 0.0:
                    continue
                wb = (d11 * d20 - d01 * d21) / den
                wc = (d00 * d21 - d01 * d20) / den
                wa = 1.0 - wb - wc
                if wa < -W_TOL or wb < -W_TOL or wc < -W_TOL:
                    continue
                _spring(p, g, nx_, ny_, nz_, wa, wb, wc, a, b, cc, k, r_c, fp, fn, out)
                n_in += 1
                if g < 0.0:
                    behind = True
                break  # one triangle per face (the diagonal belongs to the first)
        if n_in > 0:
            out[1] += 1.0
        if behind:
            out[3] += 1.0


@numba.njit(cache=True)
def inside_living(px, x, hexes, grid, tol, depth):
    """Per particle, how deep it lies inside a living hexahedron (the rows of ``hexes``): the smallest
    distance to the six face planes (each through its face's centroid, normal (x2 - x0) x (x3 - x1)
    outward) when it is behind all six by more than ``tol``, else 0, into depth (np). Returns the count."""
    start, ent = bin_boxes(x, hexes, 8, grid, 0.0)
    cell = grid[3]
    nx, ny, nz = int(grid[4]), int(grid[5]), int(grid[6])
    n_in = 0
    for p in range(px.shape[1]):
        qx, qy, qz = px[0, p], px[1, p], px[2, p]
        c = (_cell(qz, grid[2], cell, nz) * ny + _cell(qy, grid[1], cell, ny)) * nx + _cell(qx, grid[0], cell, nx)
        deepest = 0.0
        for m in range(start[c], start[c + 1]):
            e = ent[m]
            dmin = 1e300
            for f in range(6):
                n0 = hexes[e, HEX_FACES[f, 0]]
                n1 = hexes[e, HEX_FACES[f, 1]]
                n2 = hexes[e, HEX_FACES[f, 2]]
                n3 = hexes[e, HEX_FACES[f, 3]]
                ax, ay, az = x[0, n2] - x[0, n0], x[1, n2] - x[1, n0], x[2, n2] - x[2, n0]
                bx, by, bz = x[0, n3] - x[0, n1], x[1, n3] - x[1, n1], x[2, n3] - x[2, n1]
                nx_ = ay * bz - az * by
                ny_ = az * bx - ax * bz
                nz_ = ax * by - ay * bx
                ln = math.sqrt(nx_ * nx_ + ny_ * ny_ + nz_ * nz_)
                if ln <= 0.0:
                    dmin = -1.0
                    break
                cx = 0.25 * (x[0, n0] + x[0, n1] + x[0, n2] + x[0, n3])
                cy = 0.25 * (x[1, n0] + x[1, n1] + x[1, n2] + x[1, n3])
                cz = 0.25 * (x[2, n0] + x[2, n1] + x[2, n2] + x[2, n3])
                dist = ((cx - qx) * nx_ + (cy - qy) * ny_ + (cz - qz) * nz_) / ln
                if dist < dmin:
                    dmin = dist
                if dmin <= tol:
                    break
            if dmin > tol and dmin > deepest:
                deepest = dmin
        depth[p] = deepest
        if deepest > 0.0:
            n_in += 1
    return n_in
