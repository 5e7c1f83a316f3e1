"""Particle - finite-element coupling of the hybrid: particles against the exposed element edges.

Node-to-segment penalty with the particle as the node (Belytschko, Liu & Moran, "Nonlinear Finite
Elements for Continua and Structures", 2nd ed., sec. 10.4; the particle-to-segment contact of
Johnson's SPH-FE coupling, Int. J. Numer. Meth. Eng. 37 (1994) 2469, and of LAMMPS SMD's
smd/tri_surface): a particle closer than the contact radius r_c to an exposed edge (a, b) of the
surviving elements, gap g = (x_p - x_a) . n along the edge's outward normal n in [0, r_c), projection
s = (x_p - x_a) . (x_b - x_a) / |x_b - x_a|^2 in [0, 1], is pushed out by

    f = min( k (r_c - g - d0),  m_p ((v_sep - v_n) / dt + a_in) ),   v_n = (v_p - (1 - s) v_a - s v_b) . n,
                                                                    a_in = max(0, -a_o . n)

and the edge's nodes take -(1 - s) f n and -s f n (action = reaction). d0 is the pair's offset: each
particle remembers its contact pairs (edge keys, offsets and compressions in the hybrid's pair memory,
:data:`PAIR_ROWS`), as explicit codes keep a contact state per slave node and segment. A pair new in
reach starts compressed by what the step's relative approach explains, max(0, -v_n) dt, and by the
compression the particle carried at its last step, none for a particle just converted or put on an
edge: a particle born within r_c of an edge (in a squashed element of the chip), put on one (below), or
reached by an edge newly exposed beside it or by the next face at a concave corner finds the spring
compressed by no motion of its own and would be launched by that energy (the treatment of initial
penetrations in explicit codes); one sliding from edge to edge along a surface
keeps its load. While in reach d0 = min(d0, r_c - g). The offset is per pair, not per particle, so the
next face at a corner does not push with the overlap the particle found at the last one.

The second bound is a separation-speed limit (per edge): a pair overlapping by more
than it can give back in a step leaves at most at the speed v_sep (the scene's tool speed); f = 0 once
it separates faster. It holds back only what would launch the particle, never what the other forces
on it press into the edge (a_o: the acceleration that the particle's stress, the tool and the external
forces give it in this step): a particle pressed against an element by the tool or by the chip behind
it passes the load on, as a contact does. (Bounded by m_p v_sep / dt alone, a quick scene's particle
at speed scaling 250 could pass on a few N/mm, less than the tool presses it with, and was pushed
through the element, to be put back out as below, 4e5 times in a quick run at rake 0.) The spring
keeps its compression (were it to slip to the force it acted
with, particles would come to rest on their edge's line with no range left and be carried into the
elements over and over). The springs' energy k c^2 / 2 is a state of the
pairs, and what they dissipate by design (the force the limit holds back, along the path; the energy of
a compressed pair that leaves reach or is forgotten, less what a carried compression adds) is booked:
the coupling's energy balance closes on the forces' work and these.

The penalty keeps a particle from entering; one that is inside a living element anyway (carried in by
an element sliding past it faster than v_sep, or born inside one that had ridden over its neighbour)
is put out of every living element after the drift, at the springs' rest distance r_c in front of the
nearest boundary edge, with a plastic impact on that edge (:func:`expel_from_elements`): no particle stays inside an intact element
for longer than one particle step. So when the penalty acts no particle is inside a living element,
and a particle behind an edge's line (g < 0) is beyond that element's other sides, past a corner or
across a thin piece, where other edges are its business: an edge pushes only particles in front of it
(pushing those up to half its length behind would push them sideways at a corner).

The particle side runs at every SPH step (:func:`solver.sph.loop.advance`); in lockstep (the default,
:mod:`solver.hybrid.coupler`) each particle step is an engine step, the edges where the engine put them at
its end, and the nodes take the reactions as forces in the next engine step.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..binning import count_boxes, fill_boxes
from ..contact import node_segment_push
from ..tool import out_of_tool
from . import pair_memory
from .pair_memory import KEY_BASE, find_slot, forget_all, store_slots
from .particles import AX, AY, M, VX, VY, X, Y


@numba.njit(cache=True, inline="always")
def _cells_around(xi, yi, x0, y0, cell, ncx, ncy):
    """The 3 x 3 block of a cell list around the point's cell, clamped to the grid, as inclusive
    ranges x_lo, x_hi, y_lo, y_hi (empty, x_lo > x_hi or y_lo > y_hi, for a point more than a cell
    outside the grid)."""
    cx = int(math.floor((xi - x0) / cell))
    cy = int(math.floor((yi - y0) / cell))
    return max(cx - 1, 0), min(cx + 1, ncx - 1), max(cy - 1, 0), min(cy + 1, ncy - 1)


@numba.njit(cache=True, inline="always")
def edges_around(xi, yi, x0, y0, cell, ncx, ncy, estart, eitems, nearby):
    """The edges of the edge cell list (eitems[estart[c]:estart[c + 1]] in cell c) in the 3 x 3 cells
    around the point (:func:`_cells_around`), into ``nearby`` (room for every edge), cell by cell in row
    order, each cell's in its list's order; returns how many."""
    x_lo, x_hi, y_lo, y_hi = _cells_around(xi, yi, x0, y0, cell, ncx, ncy)
    n = 0
    for yy in range(y_lo, y_hi + 1):
        for xx in range(x_lo, x_hi + 1):
            cid = yy * ncx + xx
            for q in range(estart[cid], estart[cid + 1]):
                nearby[n] = eitems[q]
                n += 1
    return n


#: contact pairs a particle remembers (edges in reach at once; more are rare: a particle in a crevice)
NPAIR = 4
#: rows of the pair memory (:func:`new_pair_memory`): [0] the particle's carried compression, then per slot
#: j the edge's key (row 1 + 4 j; 0: empty), its offset d0 (2 + 4 j), its compression c = r_c - g - d0
#: (3 + 4 j) and the force the separation-speed limit held back of k c (4 + 4 j), all at the last step
STRIDE = 4
PAIR_ROWS = 1 + STRIDE * NPAIR


def new_pair_memory(n: int) -> np.ndarray:
    """The pair memory of n particles, float64[PAIR_ROWS, n], all slots empty (allocated by the hybrid only:
    a scene without element edges keeps none; :mod:`solver.sph.pair_memory`)."""
    return pair_memory.new_pair_memory(n, NPAIR, STRIDE)


def spring_energy(pairs: np.ndarray, k: float) -> float:
    """E_s [J/m]: the energy the contact springs of the pair memory hold, k c^2 / 2 summed over every
    slot's compression c (rows 3 + 4 j)."""
    return pair_memory.spring_energy(pairs, k, STRIDE)


@numba.njit(cache=True)
def particle_edge_contact(F, act, n_act, edges, ex, ey, evx, evy, x0, y0, cell, ncx, ncy, estart, eitems, k_pen, r_c,
                          v_sep, dt, dt_lim, fxp, fyp, fxn, fyn, pairs, out):
    """The coupling forces of one SPH step (module docstring), with the contact state of each pair.

    ``edges`` (n, >=2) node pairs into the node arrays ex, ey (positions) and evx, evy (velocities);
    the edges are binned by midpoint in a cell list (the edges of cell c are eitems[estart[c]:estart[c + 1]],
    :func:`solver.contact._build_cells`) of cell size at least the longest edge + r_c, searched over the 3 x 3
    cells around the particle (:func:`edges_around`). Forces are
    *added* to fxp, fyp (particles, by particle index) and fxn, fyn (nodes). Every edge the particle is
    within reach of acts (a particle in a crevice between two pieces is pushed out of all of them); a
    particle behind an edge's line (g < 0) is not its business (module docstring).

    Each pair (particle, edge) in reach has its own offset d0 (``pairs``, :data:`PAIR_ROWS`), kept while
    the pair stays in reach: d0 = min(d0, r_c - g) (a contact that opens further than its offset starts
    again from there), the spring acting on the compression c = r_c - g - d0. A pair new in reach starts
    compressed by what its relative approach in this step explains, max(0, -v_n) dt (as a node enters the
    engine's fragment contact), plus the compression the particle carried at its last step (the largest
    of its pairs'): a particle sliding along a surface from one edge to the next keeps its load, and one
    that comes within reach of an edge it was not pressed against (an edge newly exposed beside it, the
    next face at a concave corner) is not pushed by an overlap no motion of its own made. The
    separation-speed limit spreads its velocity change over max(dt, dt_lim) (a step cut short to land on
    a sample time would make its force m dv / dt huge) and adds what the particle's other forces press
    into the edge, m a_in from F[AX], F[AY] (the caller computes those forces first,
    :func:`solver.sph.loop.advance`); the spring keeps its compression, the force it acts with is less.

    The springs' energy E_s = k c^2 / 2 is a state of the pairs, and the coupling's balance books what
    the pairs dissipate by design into out[3] [J/m]: the limit's share along the path, the trapezoid
    (h_prev + h) (c_prev - c) / 2 of the force held back h = k c - f over the compression's change since
    the last step (the leapfrog pays a change of c at the mean of the forces at its two ends; a pair
    that leaves reach holds back all of k c at its end), and the jumps of E_s: + k c^2 / 2 when a pair
    leaves reach across the edge's ends or behind its line, its edge dies or it has no slot, - k c^2 / 2
    of the carried part when a new pair starts with it. out[0] = max(out[0], deepest overlap r_c - g
    [m]), out[1] += particles in contact.
    """
    dt_cap = max(dt, dt_lim)
    half_k = 0.5 * k_pen
    new = np.zeros((STRIDE, NPAIR))  # the slots kept this step: key, d0, c, held
    seen = np.zeros(NPAIR, np.bool_)
    nearby = np.empty(eitems.shape[0], np.int64)  # the edges around a particle
    for k in range(n_act):
        i = act[k]
        xi = F[X, i]
        yi = F[Y, i]
        n_near = edges_around(xi, yi, x0, y0, cell, ncx, ncy, estart, eitems, nearby)
        carried = pairs[0, i]
        for j in range(NPAIR):
            seen[j] = False
        n_new = 0
        c_max = 0.0
        touched = False
        for t in range(n_near):
            e = nearby[t]
            a = edges[e, 0]
            b = edges[e, 1]
            s, g, nx, ny = _gap(xi, yi, a, b, ex, ey)
            in_reach = 0.0 <= s <= 1.0 and 0.0 <= g < r_c
            key = a * KEY_BASE + b + 1.0
            slot = find_slot(pairs, i, STRIDE, NPAIR, key)
            o = r_c - g
            if slot >= 0:
                seen[slot] = True
                c_prev = pairs[3 + STRIDE * slot, i]
                h_prev = pairs[4 + STRIDE * slot, i]
                if not in_reach:  # it leaves: the path to its compression here, then its spring is gone
                    c_end = max(0.0, min(o, r_c) - pairs[2 + STRIDE * slot, i])
                    out[3] += 0.5 * (h_prev + k_pen * c_end) * (c_prev - c_end) + half_k * c_end * c_end
                    continue
            elif not in_reach:
                continue
            vn = ((F[VX, i] - (1.0 - s) * evx[a] - s * evx[b]) * nx
                  + (F[VY, i] - (1.0 - s) * evy[a] - s * evy[b]) * ny)
            if slot >= 0:
                d0 = min(pairs[2 + STRIDE * slot, i], o)
            else:  # new: what its approach in this step explains, and the carried compression
                explained = max(0.0, -vn) * dt
                d0 = max(0.0, o - explained - carried)
                # the kick pays the approach's part; the carried part is a jump of E_s
                c_prev = max(0.0, o - d0 - explained)
                h_prev = 0.0
                out[3] -= half_k * c_prev * c_prev
            c = o - d0
            f = k_pen * c
            if c > 0.0:
                # what the other forces press into the edge: the limit does not let them push through
                a_in = max(0.0, -(F[AX, i] * nx + F[AY, i] * ny))
                f = max(0.0, min(f, F[M, i] * ((v_sep - vn) / dt_cap + a_in)))
            held = k_pen * c - f
            out[3] += 0.5 * (h_prev + held) * (c_prev - c)
            if f > 0.0:
                node_segment_push(fxp, fyp, i, fxn, fyn, a, b, s, f, nx, ny)
                touched = True
                if o > out[0]:
                    out[0] = o
            if n_new < NPAIR:
                new[0, n_new] = key
                new[1, n_new] = d0
                new[2, n_new] = c
                new[3, n_new] = held
                n_new += 1
            else:  # no slot left: forgotten now, new again next step
                out[3] += half_k * c * c
            if c > c_max:
                c_max = c
        # pairs whose edge is gone (its element died) or out of the cells searched: their springs with them
        store_slots(pairs, i, STRIDE, NPAIR, seen, new, n_new, half_k, out, 3)
        pairs[0, i] = c_max
        if touched:
            out[1] += 1.0


@numba.njit(cache=True, inline="always")
def _gap(xi, yi, a, b, ex, ey):
    """(s, g, nx, ny): the point's projection s = (x - x_a) . t / |t|^2 along the edge (a, b), t = x_b - x_a,
    and its gap g = (x - x_a) . n along the edge's outward normal n = (t_y, -t_x) / |t| (s = -1 for an
    edge of zero length)."""
    tx = ex[b] - ex[a]
    ty = ey[b] - ey[a]
    l2 = tx * tx + ty * ty
    if l2 <= 0.0:
        return -1.0, 0.0, 0.0, 0.0
    dx = xi - ex[a]
    dy = yi - ey[a]
    ln = math.sqrt(l2)
    nx = ty / ln
    ny = -tx / ln
    return (dx * tx + dy * ty) / l2, dx * nx + dy * ny, nx, ny


#: a point deeper than this inside every edge line of a quad is inside it [m]; a particle put on an
#: edge (a hair, 1e-9 of its length, outside) touches the element across an intact seam, it is not in it
INSIDE_TOL = 1e-12


@numba.njit(cache=True)
def bin_elements(quads, live, x, y, cell, bx0, by0, bx1, by1, grow=0.0):
    """Cell list of the living quads ``live`` (element ids) that reach into the box [bx0, bx1] x
    [by0, by1]: each goes into every cell of size ``cell`` its bounding box, grown by ``grow`` on every
    side, overlaps, so a point needs to look into its own cell only, however stretched an element is
    (with ``grow`` > 0 the list stays valid while no node has moved more than ``grow`` along x or y:
    a Verlet list's skin). Compressed rows (:mod:`solver.binning`): the elements of cell c are
    items[start[c]:start[c + 1]]. Returns start, items and grid = [x0, y0, cell, ncx, ncy]."""
    ncx = int((bx1 - bx0) / cell) + 1
    ncy = int((by1 - by0) / cell) + 1
    grid = np.array([bx0, by0, cell, float(ncx), float(ncy)])
    lo = np.empty((live.shape[0], 4), np.int64)  # the cell range of each element, -1: outside the box
    for k in range(live.shape[0]):
        q = quads[live[k]]
        xmin = min(min(x[q[0]], x[q[1]]), min(x[q[2]], x[q[3]])) - grow
        xmax = max(max(x[q[0]], x[q[1]]), max(x[q[2]], x[q[3]])) + grow
        ymin = min(min(y[q[0]], y[q[1]]), min(y[q[2]], y[q[3]])) - grow
        ymax = max(max(y[q[0]], y[q[1]]), max(y[q[2]], y[q[3]])) + grow
        if xmax < bx0 or xmin > bx1 or ymax < by0 or ymin > by1:
            lo[k, 0] = -1
            continue
        lo[k, 0] = max(int((xmin - bx0) / cell), 0)
        lo[k, 1] = min(int((xmax - bx0) / cell), ncx - 1)
        lo[k, 2] = max(int((ymin - by0) / cell), 0)
        lo[k, 3] = min(int((ymax - by0) / cell), ncy - 1)
    start = np.empty(ncx * ncy + 1, np.int64)
    total = count_boxes(lo, ncx, start)
    items = np.empty(max(total, 1), np.int64)
    fill_boxes(lo, ncx, start, items)
    for j in range(total):
        items[j] = live[items[j]]
    return start, items, grid


@numba.njit(cache=True, inline="always")
def _inside_quad(px, py, q, ex, ey):
    """True when (px, py) lies inside the convex quad with counter-clockwise nodes q, deeper than
    INSIDE_TOL behind each of its four edge lines."""
    for j in range(4):
        a = q[j]
        b = q[(j + 1) % 4]
        if a == b:  # a collapsed corner: the quad is a triangle
            continue
        tx = ex[b] - ex[a]
        ty = ey[b] - ey[a]
        if tx * (py - ey[a]) - ty * (px - ex[a]) <= INSIDE_TOL * math.sqrt(tx * tx + ty * ty):
            return False
    return True


@numba.njit(cache=True)
def elements_at(px, py, quads, ex, ey, lgrid, lstart, litems, found):
    """The living elements (ids) the point (px, py) is inside, into ``found``; returns how many (at
    most found.size). lgrid, lstart, litems: :func:`bin_elements` (a point outside its box is
    inside none)."""
    cell = lgrid[2]
    ncx = int(lgrid[3])
    ncy = int(lgrid[4])
    cx = int(math.floor((px - lgrid[0]) / cell))
    cy = int(math.floor((py - lgrid[1]) / cell))
    if cx < 0 or cy < 0 or cx >= ncx or cy >= ncy:
        return 0
    c = cy * ncx + cx
    n = 0
    for k in range(lstart[c], lstart[c + 1]):
        if n == found.size:
            break
        el = litems[k]
        if _inside_quad(px, py, quads[el], ex, ey):
            found[n] = el
            n += 1
    return n


@numba.njit(cache=True)
def depth_inside(px, py, quads, ex, ey, lgrid, lstart, litems, elem, depth):
    """For each point (px[k], py[k]) the living element it is deepest inside (elem[k], -1: none) and
    how deep (depth[k]: the distance to that element's nearest edge line, 0 when outside)."""
    found = np.empty(8, np.int64)
    for k in range(px.shape[0]):
        elem[k] = -1
        depth[k] = 0.0
        n = elements_at(px[k], py[k], quads, ex, ey, lgrid, lstart, litems, found)
        for j in range(n):
            q = quads[found[j]]
            d = math.inf
            for c in range(4):
                a = q[c]
                b = q[(c + 1) % 4]
                if a != b:
                    tx = ex[b] - ex[a]
                    ty = ey[b] - ey[a]
                    d = min(d, (tx * (py[k] - ey[a]) - ty * (px[k] - ex[a])) / math.sqrt(tx * tx + ty * ty))
            if d > depth[k]:
                depth[k] = d
                elem[k] = found[j]


@numba.njit(cache=True)
def expel_from_elements(F, act, n_act, edges, quads, ex, ey, evx, evy, x0, y0, cell, ncx, ncy, estart, eitems,
                        lgrid, lstart, litems, impacts, nmass, jxn, jyn, pairs, k_pen, r_c, tool, has_tool, out):
    """Particles never inside a surviving element: the kinematic contact condition of a rigid-body
    collision with the boundary of the elements.

    A particle found inside a living quad (point in a convex quad, :func:`elements_at`) goes out of every
    living element, in front of the nearest foot of its perpendicular on a boundary edge (a, b) within
    reach, at s in [0, 1] along the edge, whose place in front lies inside no living element (the
    nearest foot can lie inside another element where elements slid over each other, or the particle
    can be in an element with no boundary edge of its own, e.g. inside a fibre two elements thick;
    with no free place in reach, in front of the nearest foot). This is the closest-point projection onto the
    admissible set, the gap condition g >= 0 of the node-to-segment contact (Belytschko, Liu & Moran
    2014, sec. 10.3-10.4) imposed on the position, as the kinematic contact of explicit codes does
    (Hallquist, Goudreau & Benson, Comput. Meth. Appl. Mech. Eng. 51 (1985) 107). The place is at the
    springs' rest distance r_c in front of the foot along the edge's outward normal, where the particle's
    new pair with the edge starts unstrained with the whole contact radius to push back with (put a hair in
    front, a particle that the tool or the chip presses on the edge would sink back in at once, its new
    spring having no range, and be put out again step after step); where that place is
    inside another element (a crevice narrower than r_c), a hair (1e-9 of the edge) in front; either place,
    if inside the tool (``has_tool``, :func:`solver.tool.out_of_tool`), goes onto the tool's surface along its
    normal (put inside it, the particle would be flung out by the tool's penalty, whose energy the move would
    have made), as the 3D hybrid's :func:`solver.hybrid.faces3d.expel_from_hexes` does. Where an element
    overlaps the tool (its nodes held by the tool's penalty), the tool's surface can lie inside it: with no
    free place, the particle goes onto the tool's surface in front of the nearest foot and is pinched there
    between the two penalties. Its velocity relative to the edge along the
    outward normal n, v_n = (v_p - (1 - s) v_a - s v_b) . n, if negative (still going in), is
    cancelled by a perfectly plastic impact of the particle with the edge point: the impulse
    J = -mu v_n n with the reduced mass mu = 1 / (1 / m_p + 1 / M), M the edge point's mass,
    1 / M = (1 - s)^2 / M_a + s^2 / M_b from the nodes' masses ``nmass`` (infinite: a rigid wall, mu = m_p),
    so both move together along n once the nodes have taken the impulses -(1 - s) J and -s J, added to
    jxn, jyn (momentum exchanged in full); it loses (1/2) mu v_n^2. (Cancelling v_n as against a rigid
    wall and booking (1/2) m_p v_n^2 would make energy when the nodes are about as heavy as the particle.)
    With ``impacts`` False positions only.

    The penalty of :func:`particle_edge_contact` keeps a particle from entering an element; this takes
    out one that got in anyway: born inside an element that had ridden over its neighbour, or carried
    in by a sliding element faster than the penalty's separation-speed limit lets it out.
    out[0] += particles moved, out[1] = max(out[1], largest depth: distance to the foot [m]), out[2] += the impulses' work on
    the particles (the kinetic energy the plastic impacts took from them, <= 0) [J/m], out[3] +=
    particles put on a foot inside another element (no free foot in reach), out[4] += particles with
    no boundary edge in reach (left where they are), out[5] += (1/2) mu v_n^2, the energy the plastic
    impacts lose (the coupling's dissipation by design), out[6] +=
    the energy k c^2 / 2 its contact pairs' springs held, forgotten (``pairs``: its contacts from the edge
    start unstrained; :func:`particle_edge_contact`)."""
    found = np.empty(8, np.int64)
    nearby = np.empty(eitems.shape[0], np.int64)  # the edges around a particle
    for k in range(n_act):
        i = act[k]
        xi = F[X, i]
        yi = F[Y, i]
        n_in = elements_at(xi, yi, quads, ex, ey, lgrid, lstart, litems, found)
        if n_in == 0:
            continue
        n_near = edges_around(xi, yi, x0, y0, cell, ncx, ncy, estart, eitems, nearby)
        best = math.inf  # the nearest free foot
        near = math.inf  # the nearest foot
        ba = -1
        bb = -1
        bs = 0.0
        na = -1
        nb = -1
        ns = 0.0
        bx = 0.0  # the place of the nearest free foot and of the nearest foot
        by = 0.0
        nxp = 0.0
        nyp = 0.0
        for t in range(n_near):
            e = nearby[t]
            a = edges[e, 0]
            b = edges[e, 1]
            tx = ex[b] - ex[a]
            ty = ey[b] - ey[a]
            l2 = tx * tx + ty * ty
            if l2 > 0.0:
                s = min(1.0, max(0.0, ((xi - ex[a]) * tx + (yi - ey[a]) * ty) / l2))
                d = math.hypot(xi - ex[a] - s * tx, yi - ey[a] - s * ty)
                if d >= near and d >= best:
                    continue
                ln = math.sqrt(l2)
                fx = ex[a] + s * tx  # the foot, and the unit outward normal (ty, -tx) / ln
                fy = ey[a] + s * ty
                gx = fx + r_c * ty / ln  # r_c in front, out of the tool
                gy = fy - r_c * tx / ln
                if has_tool != 0:
                    gx, gy = out_of_tool(gx, gy, tool)
                if d < near:
                    near, na, nb, ns, nxp, nyp = d, a, b, s, gx, gy
                if d < best:  # free: inside no element; at r_c in front, else a hair in front
                    if elements_at(gx, gy, quads, ex, ey, lgrid, lstart, litems, found) == 0:
                        best, ba, bb, bs, bx, by = d, a, b, s, gx, gy
                    else:
                        hx = fx + 1e-9 * ty
                        hy = fy - 1e-9 * tx
                        if has_tool != 0:
                            hx, hy = out_of_tool(hx, hy, tool)
                        if elements_at(hx, hy, quads, ex, ey, lgrid, lstart, litems, found) == 0:
                            best, ba, bb, bs, bx, by = d, a, b, s, hx, hy
        if ba < 0:
            if na < 0:
                out[4] += 1.0
                continue
            out[3] += 1.0
            best, ba, bb, bs, bx, by = near, na, nb, ns, nxp, nyp
        tx = ex[bb] - ex[ba]
        ty = ey[bb] - ey[ba]
        ln = math.sqrt(tx * tx + ty * ty)
        nx = ty / ln
        ny = -tx / ln
        # in front of the edge, its edge contacts starting unstrained
        F[X, i] = bx
        F[Y, i] = by
        forget_all(pairs, i, STRIDE, NPAIR, 0.5 * k_pen, out, 6)
        out[0] += 1.0
        if best > out[1]:
            out[1] = best
        if impacts:
            vn = ((F[VX, i] - (1.0 - bs) * evx[ba] - bs * evx[bb]) * nx
                  + (F[VY, i] - (1.0 - bs) * evy[ba] - bs * evy[bb]) * ny)
            if vn < 0.0:
                m = F[M, i]
                mu = 1.0 / (1.0 / m + (1.0 - bs) * (1.0 - bs) / nmass[ba] + bs * bs / nmass[bb])
                ke0 = F[VX, i] * F[VX, i] + F[VY, i] * F[VY, i]
                F[VX, i] -= mu / m * vn * nx
                F[VY, i] -= mu / m * vn * ny
                out[2] += 0.5 * m * (F[VX, i] * F[VX, i] + F[VY, i] * F[VY, i] - ke0)
                out[5] += 0.5 * mu * vn * vn  # what the plastic impact loses
                jx = -mu * vn * nx  # the impulse on the particle
                jy = -mu * vn * ny
                jxn[ba] -= (1.0 - bs) * jx
                jyn[ba] -= (1.0 - bs) * jy
                jxn[bb] -= bs * jx
                jyn[bb] -= bs * jy
