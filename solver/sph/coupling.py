"""Particle - finite-element coupling of the hybrid: particles against the exposed element edges.

Node-to-segment penalty with the particle as the node (Belytschko, Liu & Moran, "Nonlinear Finite
Elements for Continua and Structures", 2nd ed., sec. 10.4; the particle-to-segment contact of
Johnson's SPH-FE coupling, Int. J. Numer. Meth. Eng. 37 (1994) 2469, and of LAMMPS SMD's
smd/tri_surface): a particle closer than the contact radius r_c to an exposed edge (a, b) of the
surviving elements, gap g = (x_p - x_a) . n along the edge's outward normal n, projection
s = (x_p - x_a) . (x_b - x_a) / |x_b - x_a|^2 in [0, 1], is pushed out by

    f = min( k (r_c - g),  m_p (v_sep - v_n) / dt ),   v_n = (v_p - (1 - s) v_a - s v_b) . n

and the edge's nodes take -(1 - s) f n and -s f n (action = reaction). The second bound is a
separation-speed limit (per edge): a particle found deep in an edge (born inside a squashed element, or
driven in during a long step) leaves it at most at the speed v_sep (the scene's tool speed)
instead of being launched by the energy stored in a deep penalty spring; f = 0 once it
separates faster. The particle side runs at every SPH step (:func:`solver.sph.loop.advance`);
the edges stay where the engine left them over the particles' sub-steps and the nodes' reactions
are summed into impulses that the engine then takes as nodal forces (:mod:`solver.sph.hybrid`).
"""

from __future__ import annotations

import math

import numba

from ..contact import node_segment_push
from .particles import M, VX, VY, X, Y


@numba.njit(cache=True)
def particle_edge_contact(F, act, n_act, edges, ex, ey, evx, evy, x0, y0, cell, ncx, ncy, head, nxt, k_pen, r_c,
                          v_sep, dt, fxp, fyp, fxn, fyn, out):
    """The coupling forces of one SPH step (module docstring).

    ``edges`` (n, >=2) node pairs into the node arrays ex, ey (positions) and evx, evy (velocities);
    the edges are binned by midpoint in a linked cell list (head per cell, nxt per edge) of cell size
    at least the longest edge + r_c, searched over the 3 x 3 cells around the particle. Forces are
    *added* to fxp, fyp (particles, by particle index) and fxn, fyn (nodes). out[0] = max(out[0],
    deepest overlap r_c - g [m]), out[1] += particles in contact. Every edge the particle is
    within reach of acts (a particle in a crevice between two pieces, or inside
    one piece near another's surface, is pushed out of all of them, not only away from the nearest
    surface); an edge more than half its length in front of the particle is not its business (the
    particle is on the far side of a thin piece).
    """
    for k in range(n_act):
        i = act[k]
        xi = F[X, i]
        yi = F[Y, i]
        cx = int(math.floor((xi - x0) / cell))
        cy = int(math.floor((yi - y0) / cell))
        if cx < -1 or cy < -1 or cx > ncx or cy > ncy:
            continue
        touched = False
        for yy in range(max(cy - 1, 0), min(cy + 1, ncy - 1) + 1):
            for xx in range(max(cx - 1, 0), min(cx + 1, ncx - 1) + 1):
                e = head[yy * ncx + xx]
                while e >= 0:
                    a = edges[e, 0]
                    b = edges[e, 1]
                    ax = ex[a]
                    ay = ey[a]
                    tx = ex[b] - ax
                    ty = ey[b] - ay
                    l2 = tx * tx + ty * ty
                    e_next = nxt[e]
                    if l2 > 0.0:
                        dx = xi - ax
                        dy = yi - ay
                        s = (dx * tx + dy * ty) / l2
                        if 0.0 <= s <= 1.0:
                            ln = math.sqrt(l2)
                            nx = ty / ln
                            ny = -tx / ln
                            g = dx * nx + dy * ny
                            if g < r_c and g > -0.5 * ln:
                                vn = ((F[VX, i] - (1.0 - s) * evx[a] - s * evx[b]) * nx
                                      + (F[VY, i] - (1.0 - s) * evy[a] - s * evy[b]) * ny)
                                f = k_pen * (r_c - g)
                                f_cap = F[M, i] * (v_sep - vn) / dt
                                if f_cap < f:
                                    f = f_cap
                                if f > 0.0:
                                    node_segment_push(fxp, fyp, i, fxn, fyn, a, b, s, f, nx, ny)
                                    touched = True
                                    if r_c - g > out[0]:
                                        out[0] = r_c - g
                    e = e_next
        if touched:
            out[1] += 1.0
