"""Particles against the boundary faces of the surviving hexahedra: the 3D hybrid's particle-element contact.

The 3D form of the 2D hybrid's particle-edge springs (:mod:`solver.sph.coupling`), node-to-face as the 3D
engine's fragment contact (:func:`solver.fem3d.contact3d.fragment_contact3d`; Belytschko, Liu & Moran 2014,
sec. 10.4, penalty form), with the particle as the node. Each boundary face (its four nodes counter-
clockwise seen from outside, :func:`solver.fem3d.contact3d.boundary_faces`) is split into the triangles
(0, 1, 2) and (0, 2, 3) with the outward unit normal n. For a particle at p and each triangle, the
triangle's point c closest to p (:func:`closest_on_triangle`, barycentric weights w_a, w_b, w_c) gives the
overlap

    d = r_c - g,  direction n,              c inside the triangle: g = (p - c) . n, in front (g >= 0) or
                                            behind by less than d_max (half the thinnest element)
    d = r_c - |p - c|,  direction (p - c) / |p - c|,   c on an edge or a vertex, p in front of the plane

and every face in reach pushes with its nearer triangle's overlap (a face's two triangles give one spring,
their shared diagonal counted once; a particle in a closing gap or in a corner feels both sides):

    f_p = k c u                      on the particle (u the direction above)
    f_j = -w_j k c u                 on the triangle's nodes j = a, b, c (action = reaction)

on the pair's compression c = d - d0 (d0 its offset, below), with k the pair penalty PAIR_ALPHA m_min / dt^2 of :func:`solver.contact.contact_stiffness`. Each
pair's overlap is a continuous function of the particle's and the nodes' positions (across a triangle's
edges the plane gap becomes the distance to the edge, and the larger of two continuous functions is
continuous), and so is the sum: a particle sliding over a faceted fibre or into a corner meets no
spring that appears compressed by the facets. Two earlier rules made energy, found by the verification
case ``hybrid3d-momentum`` and the quick strip's cut: the plane gap alone (a spring appears compressed
where a particle enters a tilted neighbour's projection) and one face per particle (the choice flips
from step to step in a closing gap). Where two coplanar faces meet, both push a particle within r_c of
their shared edge: a ridge of at most twice the force, as wide as r_c. The forces sum to zero
(momentum is exchanged, not made); as in the fragment contact the normal's dependence on the nodes is
left out of the nodal forces (a moment of order d / face size).

Each pair has a memory, as in the 2D coupling (:func:`solver.sph.coupling.particle_edge_contact`) and as
explicit codes keep a contact state per slave node and segment: the spring acts on the compression
c = d - d0, d0 the pair's offset (:data:`PAIR_ROWS`), kept while the face stays in reach as
d0 = min(d0, d). A pair new in reach starts compressed by what the step's relative approach explains,
max(0, -v_n) dt (v_n = (v_p - sum_j w_j v_j) . u, the particle against the face's point), plus the
compression the particle carried at its last step (the largest of its pairs'): a particle born within
r_c of a neighbour's face, put in front of a face or between the tool and a face, or reached by a face
newly exposed beside it finds its spring compressed by no motion of its own, and would be launched by
that energy (the treatment of initial penetrations in explicit codes); one sliding from face to face
keeps its load. The springs' energy E_s = sum k c^2 / 2 is a state of the memory, and its jumps are
booked: + k c^2 / 2 when a pair is forgotten (its face's element died, the face left the cells searched,
no slot was free) and - k c^2 / 2 of the carried part when a new pair starts with it (out[4] of
:func:`particle_faces`). A pair that leaves reach as d falls to 0 has come back to c = 0 on the way.

The faces are binned, every evaluation, in a grid of cubic cells over the particles' bounding box
(:func:`bin_boxes`: each face in every cell its bounding box grown by the search pad overlaps; faces
outside the grid are left out). :func:`inside_living` counts particles inside a living hexahedron (behind
all six of its face planes), the check that particles do not stay inside intact elements, and
:func:`expel_from_hexes` puts one that is inside back out with a plastic impact on the face.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..binning import count_hulls3d, fill_hulls3d, point_cell3d
#: the six faces of a hexahedron (:mod:`solver.fem3d.hex8` numbering), counter-clockwise seen from outside
from ..fem3d.contact3d import HEX_FACES, triangle_normal
from ..sph import pair_memory
from ..sph.pair_memory import KEY_BASE, find_slot, forget_all, store_slots
from ..tool import out_of_tool

#: the grid's largest number of cells; a coarser cell when the particles spread farther
MAX_CELLS = 1 << 18
#: contact pairs a particle remembers (faces in reach at once: more in a corner of a fibre's facets)
NPAIR = 8
#: rows of the pair memory (:func:`new_pair_memory`): [0] the particle's carried compression, then per slot
#: j the face's key (row 1 + 3 j; 0: empty, :func:`face_key`), its offset d0 (2 + 3 j) and its compression
#: c = d - d0 (3 + 3 j), all at the last step
STRIDE = 3
PAIR_ROWS = 1 + STRIDE * NPAIR


def new_pair_memory(n: int) -> np.ndarray:
    """The pair memory of n particles, float64[PAIR_ROWS, n], all slots empty (:mod:`solver.sph.pair_memory`)."""
    return pair_memory.new_pair_memory(n, NPAIR, STRIDE)


@numba.njit(cache=True, inline="always")
def face_key(faces, e):
    """The key of face e in the pair memory: a * KEY_BASE + b + 1 for its diagonal's nodes a < b (two
    distinct faces of a conforming hexahedral mesh share at most an edge, so the diagonal names the face
    whichever living element it bounds and however the face list is rebuilt)."""
    a = min(faces[e, 0], faces[e, 2])
    b = max(faces[e, 0], faces[e, 2])
    return a * KEY_BASE + b + 1.0


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


@numba.njit(cache=True)
def bin_boxes(x, items, ncol, grid, pad):
    """CSR (start (ncells + 1), entries) of the items (rows of node ids, the first ``ncol`` columns) per
    cell of ``grid`` ([x0, y0, z0, cell, nx, ny, nz]): an item in every cell its bounding box grown by
    ``pad`` overlaps; items wholly outside the grid are left out (:func:`solver.binning.count_hulls3d`)."""
    start = np.zeros(int(grid[4]) * int(grid[5]) * int(grid[6]) + 1, np.int64)
    ent = np.empty(count_hulls3d(x, items, ncol, grid, pad, True, start), np.int64)
    fill_hulls3d(x, items, ncol, grid, pad, True, start, ent)
    return start, ent


@numba.njit(cache=True, inline="always")
def _edge_dots(abx, aby, abz, acx, acy, acz, px, py, pz, x, n):
    """(b - a) . (p - x_n) and (c - a) . (p - x_n) for the triangle's edge vectors ab, ac and its vertex n: the
    tests of the Voronoi regions of :func:`closest_on_triangle` (Ericson 2005, sec. 5.1.5)."""
    wx, wy, wz = px - x[0, n], py - x[1, n], pz - x[2, n]
    return abx * wx + aby * wy + abz * wz, acx * wx + acy * wy + acz * wz


@numba.njit(cache=True, inline="always")
def closest_on_triangle(px, py, pz, x, a, b, c):
    """Barycentric weights (wa, wb, wc) of the point of the triangle (x[:, a], x[:, b], x[:, c]) closest to p,
    and whether it lies inside the triangle (not on an edge or a vertex) (Ericson 2005, Real-Time Collision
    Detection, sec. 5.1.5, by the Voronoi regions of the vertices and edges)."""
    abx, aby, abz = x[0, b] - x[0, a], x[1, b] - x[1, a], x[2, b] - x[2, a]
    acx, acy, acz = x[0, c] - x[0, a], x[1, c] - x[1, a], x[2, c] - x[2, a]
    d1, d2 = _edge_dots(abx, aby, abz, acx, acy, acz, px, py, pz, x, a)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0, False
    d3, d4 = _edge_dots(abx, aby, abz, acx, acy, acz, px, py, pz, x, b)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0, False
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return 1.0 - v, v, 0.0, False
    d5, d6 = _edge_dots(abx, aby, abz, acx, acy, acz, px, py, pz, x, c)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0, False
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return 1.0 - w, 0.0, w, False
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - w, w, False
    den = 1.0 / (va + vb + vc)
    v = vb * den
    w = vc * den
    return 1.0 - v - w, v, w, True


@numba.njit(cache=True, inline="always")
def face_pair(qx, qy, qz, x, faces, e, r_c, d_max):
    """The spring of the particle at q against face e (module docstring): its overlap d (0: none), direction
    (ux, uy, uz), the nearer triangle's nodes (a, b, c) and barycentric weights (wa, wb, wc), and whether the
    particle was found behind the plane of a triangle that was the nearer when found."""
    best_d = 0.0
    ux = uy = uz = 0.0
    bwa = bwb = bwc = 0.0
    ba = bb = bc = 0
    behind = False
    for t in range(2):
        a = faces[e, 0]
        b = faces[e, 1 + t]
        cc = faces[e, 2 + t]
        wa, wb, wc, inner = closest_on_triangle(qx, qy, qz, x, a, b, cc)
        rx = qx - (wa * x[0, a] + wb * x[0, b] + wc * x[0, cc])
        ry = qy - (wa * x[1, a] + wb * x[1, b] + wc * x[1, cc])
        rz = qz - (wa * x[2, a] + wb * x[2, b] + wc * x[2, cc])
        nx_, ny_, nz_, a2 = triangle_normal(x, a, b, cc)
        if a2 <= 0.0:
            continue
        g = rx * nx_ + ry * ny_ + rz * nz_
        if inner:  # over the triangle: its plane's signed gap, in front or behind
            if g <= -d_max:
                continue
            d = r_c - g
            dx, dy, dz = nx_, ny_, nz_
        else:  # off an edge or a vertex, in front: the distance to it
            if g < 0.0:
                continue
            dist = math.sqrt(rx * rx + ry * ry + rz * rz)
            if dist <= 0.0:
                continue
            d = r_c - dist
            dx, dy, dz = rx / dist, ry / dist, rz / dist
        if d > best_d:  # of the face's two triangles the nearer (their shared diagonal once)
            best_d = d
            ux, uy, uz = dx, dy, dz
            bwa, bwb, bwc = wa, wb, wc
            ba, bb, bc = a, b, cc
            if inner and g < 0.0:
                behind = True
    return best_d, ux, uy, uz, ba, bb, bc, bwa, bwb, bwc, behind


@numba.njit(cache=True)
def particle_faces(px, pv, x, vn, faces, grid, k, r_c, d_max, dt, pairs, fp, fn, out):
    """The pair springs of the particles px (3, np), velocities pv, against the faces (nf, >= 4 node ids) at
    the node positions x, velocities vn, with each pair's memory ``pairs`` (:data:`PAIR_ROWS`, updated) and
    dt the step just made (module docstring): forces on the particles into fp (3, np) and on the nodes into
    fn (3, nn), both overwritten. out = [spring energy E_s [J], particles in contact, deepest overlap d,
    particles behind a face (g < 0), the memory's jumps booked [J]: + k c^2 / 2 of pairs forgotten,
    - k c^2 / 2 of the carried compression new pairs start with]."""
    for c in range(3):
        for i in range(fp.shape[1]):
            fp[c, i] = 0.0
        for i in range(fn.shape[1]):
            fn[c, i] = 0.0
    for j in range(out.shape[0]):
        out[j] = 0.0
    half_k = 0.5 * k
    if faces.shape[0] == 0:  # every pair forgotten
        for p in range(px.shape[1]):
            forget_all(pairs, p, STRIDE, NPAIR, half_k, out, 4)
        return
    if px.shape[1] == 0:
        return
    start, ent = bin_boxes(x, faces, 4, grid, r_c + d_max)
    cell = grid[3]
    nx, ny, nz = int(grid[4]), int(grid[5]), int(grid[6])
    new = np.zeros((STRIDE, NPAIR))  # the slots kept this step: key, d0, c
    seen = np.zeros(NPAIR, np.bool_)
    for p in range(px.shape[1]):
        qx, qy, qz = px[0, p], px[1, p], px[2, p]
        c = point_cell3d(qx, qy, qz, grid[0], grid[1], grid[2], cell, nx, ny, nz)
        carried = pairs[0, p]
        for j in range(NPAIR):
            seen[j] = False
        n_new = 0
        c_max = 0.0
        touched = False
        behind = False
        for m in range(start[c], start[c + 1]):
            e = ent[m]
            d, ux, uy, uz, ba, bb, bc, bwa, bwb, bwc, bh = face_pair(qx, qy, qz, x, faces, e, r_c, d_max)
            if bh:
                behind = True
            key = face_key(faces, e)
            slot = find_slot(pairs, p, STRIDE, NPAIR, key)
            if slot >= 0:
                seen[slot] = True
            if d <= 0.0:  # out of reach (a remembered pair has come back to c = 0 on its way out)
                continue
            if slot >= 0:
                d0 = min(pairs[2 + STRIDE * slot, p], d)
            else:  # new: what its approach in this step explains, and the carried compression
                v_n = 0.0
                for cc in range(3):
                    vf = bwa * vn[cc, ba] + bwb * vn[cc, bb] + bwc * vn[cc, bc]
                    u = ux if cc == 0 else (uy if cc == 1 else uz)
                    v_n += (pv[cc, p] - vf) * u
                explained = max(0.0, -v_n) * dt
                d0 = max(0.0, d - explained - carried)
                c_carried = min(carried, max(0.0, d - explained))  # the part of c = d - d0 it carried
                out[4] -= half_k * c_carried * c_carried
            cp = d - d0
            if cp > 0.0:
                f = k * cp
                fx, fy, fz = f * ux, f * uy, f * uz
                fp[0, p] += fx
                fp[1, p] += fy
                fp[2, p] += fz
                fn[0, ba] -= bwa * fx
                fn[1, ba] -= bwa * fy
                fn[2, ba] -= bwa * fz
                fn[0, bb] -= bwb * fx
                fn[1, bb] -= bwb * fy
                fn[2, bb] -= bwb * fz
                fn[0, bc] -= bwc * fx
                fn[1, bc] -= bwc * fy
                fn[2, bc] -= bwc * fz
                touched = True
            if d > out[2]:
                out[2] = d
            if n_new < NPAIR:
                new[0, n_new] = key
                new[1, n_new] = d0
                new[2, n_new] = cp
                n_new += 1
                out[0] += half_k * cp * cp
            else:  # no slot left: forgotten now, new again next step
                out[4] += half_k * cp * cp
            if cp > c_max:
                c_max = cp
        # pairs whose face is gone (its element died) or out of the cells searched: their springs with them
        store_slots(pairs, p, STRIDE, NPAIR, seen, new, n_new, half_k, out, 4)
        pairs[0, p] = c_max
        if touched:
            out[1] += 1.0
        if behind:
            out[3] += 1.0


@numba.njit(cache=True, inline="always")
def depth_in_hex(qx, qy, qz, x, hexes, e):
    """How far the point q lies behind the nearest of hexahedron e's six face planes (each through its face's
    centroid, normal (x2 - x0) x (x3 - x1) outward); <= 0 when it is in front of one (outside), -1 for a
    face of zero area."""
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
            return -1.0
        cx = 0.25 * (x[0, n0] + x[0, n1] + x[0, n2] + x[0, n3])
        cy = 0.25 * (x[1, n0] + x[1, n1] + x[1, n2] + x[1, n3])
        cz = 0.25 * (x[2, n0] + x[2, n1] + x[2, n2] + x[2, n3])
        dist = ((cx - qx) * nx_ + (cy - qy) * ny_ + (cz - qz) * nz_) / ln
        if dist < dmin:
            dmin = dist
        if dmin <= 0.0:
            return dmin
    return dmin


@numba.njit(cache=True, inline="always")
def deepest_in(qx, qy, qz, x, hexes, start, ent, c, tol):
    """How deep the point q (in grid cell c of the hexahedra's bins start, ent) lies inside the living
    hexahedron it is deepest in: the largest :func:`depth_in_hex` above ``tol``, else 0."""
    deepest = 0.0
    for m in range(start[c], start[c + 1]):
        d = depth_in_hex(qx, qy, qz, x, hexes, ent[m])
        if d > tol and d > deepest:
            deepest = d
    return deepest


@numba.njit(cache=True)
def inside_living(px, x, hexes, grid, tol, depth):
    """Per particle, how deep it lies inside a living hexahedron (the rows of ``hexes``, :func:`deepest_in`:
    behind all six face planes by more than ``tol``; else 0), into depth (np). Returns the count."""
    start, ent = bin_boxes(x, hexes, 8, grid, 0.0)
    cell = grid[3]
    nx, ny, nz = int(grid[4]), int(grid[5]), int(grid[6])
    n_in = 0
    for p in range(px.shape[1]):
        qx, qy, qz = px[0, p], px[1, p], px[2, p]
        c = point_cell3d(qx, qy, qz, grid[0], grid[1], grid[2], cell, nx, ny, nz)
        depth[p] = deepest_in(qx, qy, qz, x, hexes, start, ent, c, tol)
        if depth[p] > 0.0:
            n_in += 1
    return n_in


@numba.njit(cache=True)
def expel_from_hexes(px, pv, pm, x, vn, invm, hexes, faces, grid, reach, k, r_c, tol, tool, zlo, zhi, pairs, jn,
                     out):
    """Particles never inside a surviving hexahedron: the 3D form of the 2D hybrid's
    :func:`solver.sph.coupling.expel_from_elements` (the kinematic contact condition of a rigid-body
    collision with the elements' boundary; Belytschko, Liu & Moran 2014, sec. 10.3-10.4; Hallquist,
    Goudreau & Benson, Comput. Meth. Appl. Mech. Eng. 51 (1985) 107).

    A particle deeper than ``tol`` inside a living hexahedron (:func:`deepest_in`) goes to the point at the
    springs' rest distance r_c in front of the nearest boundary-face point c within ``reach``, c + r_c n
    (n the outward normal of c's triangle), that lies inside no living hexahedron (with none in reach, in
    front of the nearest point; with no face in reach it stays), its z kept within [zlo, zhi] (the strip's
    sides, where the particles' walls are: a point beyond them would have the walls launch it): there its
    spring against that face is unstrained, as a 2D particle put on an edge starts its pair unstrained. A
    place inside the tool (``tool``: :func:`solver.tool.tool_array`'s layout, extruded along z; empty: no
    tool) goes onto the tool's surface along its normal (:func:`solver.tool.out_of_tool`), between the tool and
    the face, within r_c of it: put inside the tool, the particle would be flung out by the tool's penalty,
    whose energy k m g^2 / 2 the move would have made. Its velocity relative to the
    triangle's three nodes moving as one body, v_n = (v_p - v_T) . n with v_T = sum_j M_j v_j / M_T and
    M_T = sum_j M_j (``invm``: the nodes' 1 / M), if negative, is cancelled by a perfectly plastic impact of
    the two: the impulse J = -mu v_n n on the particle, mu = 1 / (1 / m_p + 1 / M_T), and -J M_j / M_T on
    node j (added to jn (3, nn), for the nodes' next step: each changes its velocity by the same -J / M_T,
    so a light node at a corner is not flung); it loses (1/2) mu v_n^2. A triangle with a node that does
    not move freely (1 / M = 0: a support) is rigid: mu = m_p, v_T the velocity of the contact point
    sum_j w_j v_j (w_j the point's barycentric weights), the impulse to the supported nodes. The particle's
    pair memory (``pairs``, :data:`PAIR_ROWS`) is cleared: its springs' energy k c^2 / 2 goes with the move
    (booked), and at its new place its pairs start new, compressed only by what their approach explains
    (:func:`particle_faces`), so a spring it finds compressed between the tool and a face does not launch it.
    out[0] += particles moved, out[1] = max(out[1], largest move [m]), out[2] += the impulses' work on
    the particles [J], out[3] += particles put in front of a point inside another element (none free in
    reach), out[4] += particles with no face in reach (left where they are), out[5] += (1/2) mu v_n^2
    [J], out[6] += the energy k c^2 / 2 of the pairs forgotten [J]."""
    if hexes.shape[0] == 0 or px.shape[1] == 0:
        return
    hstart, hent = bin_boxes(x, hexes, 8, grid, 0.0)
    cell = grid[3]
    nx, ny, nz = int(grid[4]), int(grid[5]), int(grid[6])
    fstart = np.zeros(1, np.int64)
    fent = np.zeros(0, np.int64)
    binned = False
    bsel = np.zeros(6)  # (face point + r_c n (3), n (3)) of the nearest free point
    nsel = np.zeros(6)  # of the nearest point
    bn = np.zeros(6, np.int64)  # the nodes of their triangles (3 + 3)
    bw = np.zeros(6)  # and the weights of their points
    for p in range(px.shape[1]):
        qx, qy, qz = px[0, p], px[1, p], px[2, p]
        c = point_cell3d(qx, qy, qz, grid[0], grid[1], grid[2], cell, nx, ny, nz)
        if deepest_in(qx, qy, qz, x, hexes, hstart, hent, c, tol) <= 0.0:
            continue
        if not binned:  # the faces within reach of each cell, once a particle needs them
            fstart, fent = bin_boxes(x, faces, 4, grid, reach)
            binned = True
        best = math.inf  # the nearest free point
        near = math.inf  # the nearest point
        for m in range(fstart[c], fstart[c + 1]):
            e = fent[m]
            for t in range(2):
                a = faces[e, 0]
                b = faces[e, 1 + t]
                cc = faces[e, 2 + t]
                wa, wb, wc, _ = closest_on_triangle(qx, qy, qz, x, a, b, cc)
                fx = wa * x[0, a] + wb * x[0, b] + wc * x[0, cc]
                fy = wa * x[1, a] + wb * x[1, b] + wc * x[1, cc]
                fz = wa * x[2, a] + wb * x[2, b] + wc * x[2, cc]
                d = math.sqrt((qx - fx) ** 2 + (qy - fy) ** 2 + (qz - fz) ** 2)
                if d >= near and d >= best:
                    continue
                tnx, tny, tnz, ln = triangle_normal(x, a, b, cc)
                if ln <= 0.0:
                    continue
                gx, gy, gz = fx + r_c * tnx, fy + r_c * tny, min(max(fz + r_c * tnz, zlo), zhi)
                if tool.shape[0] > 0:  # a place inside the tool goes onto its surface
                    gx, gy = out_of_tool(gx, gy, tool)
                if d < near:
                    near = d
                    nsel[0], nsel[1], nsel[2], nsel[3], nsel[4], nsel[5] = gx, gy, gz, tnx, tny, tnz
                    bn[3], bn[4], bn[5] = a, b, cc
                    bw[3], bw[4], bw[5] = wa, wb, wc
                if d < best:
                    cg = point_cell3d(gx, gy, gz, grid[0], grid[1], grid[2], cell, nx, ny, nz)
                    if deepest_in(gx, gy, gz, x, hexes, hstart, hent, cg, tol) <= 0.0:
                        best = d
                        bsel[0], bsel[1], bsel[2], bsel[3], bsel[4], bsel[5] = gx, gy, gz, tnx, tny, tnz
                        bn[0], bn[1], bn[2] = a, b, cc
                        bw[0], bw[1], bw[2] = wa, wb, wc
        o = 0  # which of the two: the nearest free point (0) or the nearest point (3)
        sel = bsel
        if best == math.inf:
            if near == math.inf:
                out[4] += 1.0
                continue
            out[3] += 1.0
            o = 3
            sel = nsel
        gx, gy, gz = sel[0], sel[1], sel[2]
        px[0, p] = gx
        px[1, p] = gy
        px[2, p] = gz
        forget_all(pairs, p, STRIDE, NPAIR, 0.5 * k, out, 6)
        out[0] += 1.0
        move = math.sqrt((gx - qx) ** 2 + (gy - qy) ** 2 + (gz - qz) ** 2)
        if move > out[1]:
            out[1] = move
        tnx, tny, tnz = sel[3], sel[4], sel[5]
        m_t = 0.0  # the triangle's mass, 0 when a node is supported (rigid)
        n_fixed = 0
        for j in range(3):
            if invm[bn[o + j]] > 0.0:
                m_t += 1.0 / invm[bn[o + j]]
            else:
                n_fixed += 1
        v_n = pv[0, p] * tnx + pv[1, p] * tny + pv[2, p] * tnz
        for j in range(3):
            node = bn[o + j]
            share = bw[o + j] if n_fixed else 1.0 / (invm[node] * m_t)
            v_n -= share * (vn[0, node] * tnx + vn[1, node] * tny + vn[2, node] * tnz)
        if v_n < 0.0:
            m = pm[p]
            mu = m if n_fixed else 1.0 / (1.0 / m + 1.0 / m_t)
            ke0 = pv[0, p] ** 2 + pv[1, p] ** 2 + pv[2, p] ** 2
            jx, jy, jz = -mu * v_n * tnx, -mu * v_n * tny, -mu * v_n * tnz  # the impulse on the particle
            pv[0, p] += jx / m
            pv[1, p] += jy / m
            pv[2, p] += jz / m
            out[2] += 0.5 * m * (pv[0, p] ** 2 + pv[1, p] ** 2 + pv[2, p] ** 2 - ke0)
            out[5] += 0.5 * mu * v_n * v_n
            for j in range(3):
                node = bn[o + j]
                if n_fixed:  # the supports take it
                    share = 0.0 if invm[node] > 0.0 else 1.0 / n_fixed
                else:
                    share = 1.0 / (invm[node] * m_t)
                jn[0, node] -= share * jx
                jn[1, node] -= share * jy
                jn[2, node] -= share * jz
