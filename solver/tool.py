"""The rigid cutting tool: exact geometry of two planes tangent to one arc (docs/model.md, "The scene").

Coordinates (contact contract): x = cutting direction, y = up; the workpiece is x in [0, L],
y in [-H, 0]; the tool starts right of it and moves in -x. The rake face faces -x and leans
back by the rake angle alpha (measured from the normal of the cut surface); the clearance
(flank) face runs from the edge towards +x, rising by the clearance angle gamma above the
machined surface. The cutting edge is an arc of radius r (r = 0: a sharp tool) whose
lowest point lies on the cut plane y = -depth.

Geometry: the rounded tool is the Minkowski sum of a sharp wedge W with its apex at the arc
centre C (faces parallel to the tool's faces) and a disc of radius r, so its exact signed
distance is ``sd_tool(p) = sd_W(p) - r`` (Minkowski sum of a convex set and a disc). For the
convex wedge: inside, ``sd_W = max(d_rake, d_clear)`` (distance to the nearest supporting
line, exact for convex sets); outside, the distance to the nearest of the two face rays
(projection onto a ray, or the apex when the projection falls behind it).

Array layout ``tool = tool_array(si)`` (float64):
    [0] x of C, [1] y of C, [2] tool velocity x (< 0), [3] tool velocity y (0), [4] r,
    [5] rake angle [rad], [6] clearance angle [rad],
    [7] cos(alpha), [8] sin(alpha), [9] cos(gamma), [10] sin(gamma),
    [11] orientation s = +1 (rake face facing -x, the contract's tool) or -1 (the mirror image
    x -> 2 x_C - x, rake face facing +x: used to check that a mirrored scene mirrors the forces).
"""

from __future__ import annotations

import math

import numba
import numpy as np

N_TOOL = 12


def tool_array(si, x_start: float | None = None, gap: float | None = None) -> np.ndarray:
    """The tool array for an SI scene: arc centre placed so the tool starts clear of the workpiece.

    The arc's lowest point is on the cut plane y = -depth. The centre's x is chosen so that
    the tool's closest point to the workpiece (the rectangle x <= L, -H <= y <= 0) is ``gap``
    away (default: half an element), unless ``x_start`` (arc centre x) is given.
    """
    alpha, gamma, r = float(si.rake), float(si.clearance), float(si.edge_radius)
    speed = float(si.speed) * float(si.numerics.speed_scaling)
    t = np.zeros(N_TOOL)
    t[1] = -float(si.depth) + r
    t[2] = -speed
    t[3] = 0.0
    t[4] = r
    t[5] = alpha
    t[6] = gamma
    t[7], t[8] = math.cos(alpha), math.sin(alpha)
    t[9], t[10] = math.cos(gamma), math.sin(gamma)
    t[11] = 1.0
    if x_start is not None:
        t[0] = x_start
        return t
    if gap is None:
        gap = 0.5 * float(si.element_size)
    t[0] = 0.0
    t[0] = float(si.length) + gap - min_x_over_band(t, -float(si.height), 0.0)
    return t


def min_x_over_band(tool: np.ndarray, y_lo: float, y_hi: float) -> float:
    """Smallest x of the tool's solid within the horizontal band y_lo <= y <= y_hi (exact)."""
    xc, yc, r = tool[0], tool[1], tool[4]
    ca, sa, cg, sg = tool[7], tool[8], tool[9], tool[10]
    cands = []
    # arc points within the band whose outward normal lies in the arc's normal cone
    # (from the clearance normal (sg, -cg) clockwise... i.e. angles 180-alpha .. 270+gamma)
    a_lo, a_hi = math.pi - math.atan2(sa, ca), 1.5 * math.pi + math.atan2(sg, cg)
    for ang in np.concatenate([np.linspace(a_lo, a_hi, 721), [math.pi]]):
        if a_lo - 1e-12 <= ang <= a_hi + 1e-12:
            px, py = xc + r * math.cos(ang), yc + r * math.sin(ang)
            if y_lo <= py <= y_hi:
                cands.append(px)
    # rake face: from its tangent point T_r = C + r n_r upward along (sa, ca)
    tx, ty = xc - r * ca, yc + r * sa
    for y in (y_lo, y_hi):
        if y >= ty and ca > 0:
            cands.append(tx + (y - ty) * sa / ca)
    # clearance face: from T_c = C + r n_c towards +x, rising; its leftmost point is T_c
    cx, cy = xc + r * sg, yc - r * cg
    if y_lo <= cy <= y_hi:
        cands.append(cx)
    if not cands:  # the band lies entirely above/below the arc: take the faces' end points
        cands.append(tx + (y_hi - ty) * sa / max(ca, 1e-12))
    return float(min(cands))


@numba.njit(cache=True, inline="always")
def tool_sdf(px, py, tool):
    """Exact signed distance from (px, py) to the tool and the outward unit normal there.

    sd = sd_W(p) - r (Minkowski sum of the sharp wedge W with apex C and a disc of radius r).
    Wedge faces through C: rake with outward normal n_r = (-cos a, sin a) and ray direction
    t_r = (sin a, cos a) (upward); clearance with n_c = (sin g, -cos g), t_c = (cos g, sin g).
    Inside W: sd_W = max(d_r, d_c) (d = (p - C) . n); outside: the distance to the nearer face
    ray (|d| where the projection s = (p - C) . t >= 0, else |p - C|).
    Returns (sd, nx, ny); negative sd = penetration depth. A mirrored tool (tool[11] = -1)
    evaluates the same at the mirrored point and mirrors the normal's x.
    """
    ca, sa, cg, sg = tool[7], tool[8], tool[9], tool[10]
    o = tool[11]
    qx = o * (px - tool[0])
    qy = py - tool[1]
    nrx, nry = -ca, sa
    ncx, ncy = sg, -cg
    dr = qx * nrx + qy * nry
    dc = qx * ncx + qy * ncy
    if dr <= 0.0 and dc <= 0.0:
        if dr >= dc:
            return dr - tool[4], o * nrx, nry
        return dc - tool[4], o * ncx, ncy
    dist_apex = math.sqrt(qx * qx + qy * qy)
    best = dist_apex
    if dist_apex > 0.0:
        bx, by = qx / dist_apex, qy / dist_apex
    else:
        bx, by = nrx, nry
    if dr > 0.0 and qx * sa + qy * ca >= 0.0 and dr < best:
        best, bx, by = dr, nrx, nry
    if dc > 0.0 and qx * cg + qy * sg >= 0.0 and dc < best:
        best, bx, by = dc, ncx, ncy
    return best - tool[4], o * bx, by


@numba.njit(cache=True, inline="always")
def out_of_tool(px, py, tool):
    """(px, py) if it lies outside the tool, else its foot on the tool's surface along the normal of
    :func:`tool_sdf` (where a particle is put that would otherwise be placed inside the tool and flung out
    by its penalty)."""
    sd, nx, ny = tool_sdf(px, py, tool)
    if sd < 0.0:
        return px - sd * nx, py - sd * ny
    return px, py


@numba.njit(cache=True)
def tool_bounds(tool):
    """(y_lo, q_lo): no point of the tool lies below y = y_lo, nor at q = tool[11] (x - tool[0]) < q_lo
    (ahead of it along its motion); -inf where there is no such bound. The sharp wedge W of
    :func:`tool_sdf` is the cone of its face rays t_r = (sin a, cos a) and t_c = (cos g, sin g) from the
    apex C; the tool, W grown by the edge radius r, lies above C_y - r when both rays rise (cos a, sin g
    >= 0) and behind q = -r when neither leans forward (sin a, cos g >= 0). A contact loop skips points
    outside these bounds without evaluating the distance (the same result: their distance is positive)."""
    ca, sa, cg, sg = tool[7], tool[8], tool[9], tool[10]
    y_lo = tool[1] - tool[4] if (ca >= 0.0 and sg >= 0.0) else -math.inf
    q_lo = -tool[4] if (sa >= 0.0 and cg >= 0.0) else -math.inf
    return y_lo, q_lo


@numba.njit(cache=True)
def tool_face(nx, ny, tool):
    """Which part of the tool a contact with outward normal (nx, ny) from :func:`tool_sdf` touches:
    0 the rake face (normal n_r), 2 the clearance face (normal n_c), 1 the cutting edge (the arc, or a
    sharp tool's apex, where the normal turns from n_r to n_c). tool_sdf returns the faces' normals
    exactly, so the test is one of equality to round-off."""
    ca, sa, cg, sg = tool[7], tool[8], tool[9], tool[10]
    o = tool[11]
    if abs(nx + o * ca) < 1e-12 and abs(ny - sa) < 1e-12:
        return 0
    if abs(nx - o * sg) < 1e-12 and abs(ny + cg) < 1e-12:
        return 2
    return 1


@numba.njit(cache=True)
def tool_sdf_many(px, py, tool, sd, nx, ny):
    """tool_sdf for arrays of points (used by outputs and tests)."""
    for i in range(px.shape[0]):
        s, a, b = tool_sdf(px[i], py[i], tool)
        sd[i] = s
        nx[i] = a
        ny[i] = b


def tool_polygon(tool: np.ndarray, length: float, n_arc: int = 40) -> np.ndarray:
    """Outline of the tool (for plots): rake face, arc and clearance face, ``length`` long each."""
    xc, yc, r = tool[0], tool[1], tool[4]
    ca, sa, cg, sg = tool[7], tool[8], tool[9], tool[10]
    a_lo, a_hi = math.pi - math.atan2(sa, ca), 1.5 * math.pi + math.atan2(sg, cg)
    tr = (xc - r * ca, yc + r * sa)
    tc = (xc + r * sg, yc - r * cg)
    pts = [(tr[0] + length * sa, tr[1] + length * ca)]
    for ang in np.linspace(a_lo, a_hi, n_arc):
        pts.append((xc + r * math.cos(ang), yc + r * math.sin(ang)))
    if r == 0.0:
        pts.append((xc, yc))
    pts.append((tc[0] + length * cg, tc[1] + length * sg))
    return np.array(pts)


def mirrored(tool: np.ndarray, x_mirror: float) -> np.ndarray:
    """The tool mirrored about the vertical line x = x_mirror (moving the opposite way)."""
    t = tool.copy()
    t[0] = 2.0 * x_mirror - tool[0]
    t[2] = -tool[2]
    t[11] = -tool[11]
    return t
