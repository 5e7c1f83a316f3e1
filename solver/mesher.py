"""The workpiece mesher: fibre/matrix micro zone, cohesive interfaces and the EHM around it.

Geometry (contact contract): the workpiece is x in [0, L], y in [-H, 0]; top free, bottom
(y = -H) and far end (x = 0) fixed. The micro zone covers the cut path and the zone ahead of
the tool's final position where the chip forms, x in [max(0, L - cut_length - 2 depth - r -
4 h), L] (the whole length for the default workpiece length), from the free surface down to
``micro_zone_depth`` below the cut plane y = -depth. Outside it the equivalent homogeneous
material (EHM) shares nodes. (With EHM ahead of the fibre ends, a 0-degree cut pushed the
fibres into the EHM block, whose Hashin shear strength is the interface's 25 MPa, and tore it
off; fibres running to the fixed end carry that load as the real ply does.)

Layout: a structured grid with one family of lines parallel to the fibres and the other
family either vertical (fibres closer to the cutting direction, |cos theta| >= |sin theta|) or
horizontal (fibres closer to the surface normal). In the local frame (u across the domain
along the second family's normal, v along it) the fibre-parallel lines are v = c_j + u t
with t = tan(theta) (vertical family) or cot(theta) (horizontal family). Inside the micro
zone's band of lines the c_j follow the 2D fibre/matrix strips: a fibre of width d_f
(``elements_across_fibre`` elements), then a matrix strip of width d_f (1 - V_f) / V_f (at
least one element); the element length along the fibre is ``element_size``. Outside the band
the lines grow geometrically coarser (EHM). For 0 and 90 degrees the grid is rectangular and
aligned; for other angles nodes beyond the domain are clipped to its boundary (nodes within
0.35 of a line spacing of the boundary snap onto it) and coincident nodes merge, so the
boundary elements next to the four sides are trapezoids or degenerate quads (triangles, with
the last node repeated).

Cohesive elements (only when ``physics.cohesive_interface``): at every fibre/matrix line
segment inside the micro zone, the fibre side's nodes are duplicated; a node touching an EHM
element or lying where several lines merge on the boundary stays shared (tied).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .mesh import EHM, FIBRE, MATRIX, Mesh


def _strip_lines(width_f: float, width_m: float, nf: int, nm: int, lo: float, hi: float, anchor: float):
    """Line offsets (c values) of fibre/matrix strips covering [lo, hi], pattern anchored at ``anchor``.

    Returns (c, kind) where kind[j] is the material of the band between c[j] and c[j+1]."""
    pitch = width_f + width_m
    k0 = math.floor((lo - anchor) / pitch) - 1
    k1 = math.ceil((hi - anchor) / pitch) + 1
    c, kind = [], []
    for k in range(k0, k1):
        base = anchor + k * pitch
        for m in range(nf):
            c.append(base + width_f * m / nf)
            kind.append(FIBRE)
        for m in range(nm):
            c.append(base + width_f + width_m * m / nm)
            kind.append(MATRIX)
    c.append(anchor + k1 * pitch)
    c, kind = np.array(c), np.array(kind[:len(c) - 1])
    # keep the strips that reach into [lo, hi]
    first = max(int(np.searchsorted(c, lo, side="right")) - 1, 0)
    last = min(int(np.searchsorted(c, hi, side="left")), len(c) - 1)
    return c[first:last + 1], kind[first:last]


def _graded(start: float, stop: float, h0: float, growth: float, hmax: float) -> np.ndarray:
    """Points from start towards stop (exclusive of start) with sizes growing by ``growth`` to ``hmax``."""
    out, pos, h = [], start, h0
    sign = 1.0 if stop > start else -1.0
    while sign * (stop - pos) > 1e-12:
        h = min(h * growth, hmax)
        if sign * (stop - pos) < 1.5 * h:  # last step lands exactly on stop
            pos = stop
        else:
            pos = pos + sign * h
        out.append(pos)
    return np.array(out)


@dataclass(frozen=True)
class StripGeometry:
    """The sizes the mesh is built from (SI): fibre angle theta in [0, pi), element size h, fibre and
    matrix strip widths d_f, d_m = d_f (1 - V_f) / V_f (the volume fraction V_f), elements across a
    fibre nf and across a matrix strip nm (about the same size), the workpiece L x H, the cut depth,
    the micro zone's depth below the surface mz_depth and its start x_ms along x."""

    theta: float
    h: float
    d_f: float
    d_m: float
    nf: int
    nm: int
    L: float
    H: float
    depth: float
    mz_depth: float
    x_ms: float


def strip_geometry(si) -> StripGeometry:
    """:class:`StripGeometry` of an SI scene (``scene.si()``): what :func:`build_mesh` meshes and
    :func:`solver.budget.estimate` counts."""
    theta = float(si.fibre_angle) % math.pi
    h = float(si.element_size)
    d_f = float(si.fibre_diameter)
    vf = float(si.fibre_volume_fraction)
    d_m = d_f * (1.0 - vf) / vf
    nf = int(si.numerics.elements_across_fibre)
    nm = max(1, int(round(nf * d_m / d_f)))
    L, H = float(si.length), float(si.height)
    depth = float(si.depth)
    mz_depth = depth + float(si.micro_zone_depth)
    x_ms = max(0.0, L - float(si.cut_length) - 2.0 * depth - float(si.edge_radius) - 4.0 * h)
    return StripGeometry(theta, h, d_f, d_m, nf, nm, L, H, depth, mz_depth, x_ms)


def build_mesh(si) -> Mesh:
    """Mesh the workpiece of an SI scene (``scene.si()``); see the module docstring."""
    g = strip_geometry(si)
    theta, h, d_f, d_m, nf, nm, L, H = g.theta, g.h, g.d_f, g.d_m, g.nf, g.nm, g.L, g.H
    depth, x_ms = g.depth, g.x_ms
    y_mz = -g.mz_depth
    cohesive_on = bool(si.physics.cohesive_interface)

    c, s = math.cos(theta), math.sin(theta)
    vertical = abs(c) >= abs(s) - 1e-12  # second family = vertical lines x = u_i
    if vertical:
        t = s / c
        cos_f = abs(c)  # u-spacing h*cos gives h along the fibre; c-offset = width / cos
        u_lo, u_hi, v_lo, v_hi = 0.0, L, -H, 0.0
        mz_u, mz_v = (x_ms, L), (y_mz, 0.0)
    else:
        t = c / s
        cos_f = abs(s)
        u_lo, u_hi, v_lo, v_hi = -H, 0.0, 0.0, L
        mz_u, mz_v = (y_mz, 0.0), (x_ms, L)

    # second-family lines: uniform, element_size along the fibre
    du_target = h * cos_f
    nu = max(1, int(math.ceil((u_hi - u_lo) / du_target - 1e-9)))
    u = np.linspace(u_lo, u_hi, nu + 1)

    # fibre-parallel lines: strips over the micro band, graded EHM outside
    wf, wm = d_f / cos_f, d_m / cos_f
    corners_mz = [(uu, vv) for uu in mz_u for vv in mz_v]
    band_lo = min(vv - uu * t for uu, vv in corners_mz)
    band_hi = max(vv - uu * t for uu, vv in corners_mz)
    corners_dom = [(uu, vv) for uu in (u_lo, u_hi) for vv in (v_lo, v_hi)]
    c_min = min(vv - uu * t for uu, vv in corners_dom)
    c_max = max(vv - uu * t for uu, vv in corners_dom)
    # a strip boundary through the cut's start corner, shifted into the workpiece by the fibre offset
    # (perpendicular to the fibres: a shift of the line offsets c by offset / cos_f)
    anchor = v_hi - u_hi * t - float(getattr(si, "fibre_offset", 0.0)) / cos_f
    cs, kinds = _strip_lines(wf, wm, nf, nm, max(band_lo, c_min), min(band_hi, c_max), anchor)
    h_strip = min(wf / nf, wm / nm)
    h_out = max(4.0 * h_strip, 4.0 * h * cos_f)
    below = _graded(cs[0], c_min, h_strip, 1.3, h_out)[::-1] if cs[0] > c_min + 1e-12 else np.zeros(0)
    above = _graded(cs[-1], c_max, h_strip, 1.3, h_out) if cs[-1] < c_max - 1e-12 else np.zeros(0)
    cl = np.concatenate([below, cs, above])
    band_kind = np.concatenate([np.full(below.size, EHM), kinds, np.full(above.size, EHM)]).astype(np.int8)
    n_c = cl.size

    # node positions in the local frame with clipping/snapping to the domain
    V = cl[None, :] + u[:, None] * t  # (nu+1, n_c)
    dv = np.diff(cl).min() if n_c > 1 else h
    snap = 0.35 * dv
    V = np.where(V > v_hi - snap, v_hi, V)
    V = np.where(V < v_lo + snap, v_lo, V)
    # merge coincident nodes (same column, same clipped v)
    ids = np.empty(V.shape, np.int64)
    xs, ys, multi = [], [], []
    for i in range(nu + 1):
        col = V[i]
        prev = None
        for j in range(n_c):
            key = col[j]
            if prev is not None and key == V[i, j - 1]:
                ids[i, j] = prev
                multi[prev] = True
                continue
            prev = len(xs)
            ids[i, j] = prev
            multi.append(False)
            if vertical:
                xs.append(u[i]); ys.append(key)
            else:
                xs.append(key); ys.append(u[i])
    x = np.array(xs); y = np.array(ys); multi = np.array(multi)

    # quads (i, j): corners (i,j), (i+1,j), (i+1,j+1), (i,j+1) CCW in (u, v)
    I, J = np.meshgrid(np.arange(nu), np.arange(n_c - 1), indexing="ij")
    q = np.stack([ids[I, J], ids[I + 1, J], ids[I + 1, J + 1], ids[I, J + 1]], axis=-1).reshape(-1, 4)
    if not vertical:  # (x, y) = (v, u) mirrors the orientation
        q = q[:, ::-1]
    band = np.broadcast_to(J, I.shape).reshape(-1)
    col_i = I.reshape(-1)
    area = _quad_area(x, y, q)
    nominal = (u[1] - u[0]) * dv
    keep = area > 1e-3 * nominal
    # normalise degenerate quads: drop the repeated node and repeat the last distinct one
    q = np.array([_normalise(row) for row in q[keep]], dtype=np.int64) if keep.any() else np.zeros((0, 4), np.int64)
    band, col_i = band[keep], col_i[keep]
    cx, cy = x[q].mean(axis=1), y[q].mean(axis=1)
    in_mz = (cx >= x_ms) & (cy >= y_mz)
    material = np.where(in_mz, band_kind[band], EHM).astype(np.int8)
    # the micro-zone test by centroid can put EHM bands inside: graded bands are EHM anyway
    elem_index = -np.ones((nu, n_c - 1), np.int64)
    elem_index[col_i, band] = np.arange(q.shape[0])

    # cohesive elements
    coh, coh_el = [], []
    if cohesive_on and q.shape[0]:
        n_nodes = x.size
        touches_ehm = np.zeros(n_nodes, bool)
        np.logical_or.at(touches_ehm, q[material == EHM].reshape(-1), True)
        dup = -np.ones(n_nodes, np.int64)
        new_x, new_y = list(x), list(y)
        q = q.copy()
        for j in range(1, n_c - 1):  # line j between band j-1 (below, in v) and band j (above)
            kb, ka = band_kind[j - 1], band_kind[j]
            if {int(kb), int(ka)} != {FIBRE, MATRIX}:
                continue
            fibre_band = j if ka == FIBRE else j - 1
            for i in range(nu):
                eb, ea = elem_index[i, j - 1], elem_index[i, j]
                if eb < 0 or ea < 0 or material[eb] == EHM or material[ea] == EHM:
                    continue
                n0, n1 = ids[i, j], ids[i + 1, j]
                if n0 == n1:
                    continue
                ef = ea if fibre_band == j else eb
                em = eb if fibre_band == j else ea
                pair = []
                for nd in (n0, n1):
                    if touches_ehm[nd] or multi[nd]:
                        pair.append(nd)
                        continue
                    if dup[nd] < 0:
                        dup[nd] = len(new_x)
                        new_x.append(x[nd]); new_y.append(y[nd])
                    pair.append(dup[nd])
                # the fibre element uses the duplicates
                for k in range(4):
                    if q[ef, k] == n0:
                        q[ef, k] = pair[0]
                    elif q[ef, k] == n1:
                        q[ef, k] = pair[1]
                coh.append((n0, n1, pair[0], pair[1]))  # a = matrix side, b = fibre side
                coh_el.append((em, ef))
        # a fibre node duplicated for one element must be duplicated in all fibre elements of the band
        # touching it: the loop above already replaced it element by element along the line; fix
        # the fibre elements that touch a duplicated node only by a corner (none in a structured grid).
        x, y = np.array(new_x), np.array(new_y)
    cohesive = np.array(coh, np.int32).reshape(-1, 4)
    cohesive_elems = np.array(coh_el, np.int32).reshape(-1, 2)

    # drop unused nodes, renumber
    used = np.zeros(x.size, bool)
    used[q.reshape(-1)] = True
    new_id = -np.ones(x.size, np.int64)
    new_id[used] = np.arange(used.sum())
    q = new_id[q]
    if cohesive.size:
        cohesive = new_id[cohesive].astype(np.int32)
    x, y = x[used], y[used]
    tol = 1e-9 * max(L, H)
    fixed = (x <= tol) | (y <= -H + tol)
    mesh = Mesh(x=x, y=y, quads=q.astype(np.int32), material=material,
                fibre_angle=np.full(q.shape[0], theta), fixed_x=fixed.copy(), fixed_y=fixed.copy(),
                cohesive=cohesive, cohesive_elems=cohesive_elems)
    mesh.info = {
        "length_m": L, "height_m": H, "cut_plane_y_m": -depth, "micro_zone": {"x_min_m": x_ms, "x_max_m": L, "y_min_m": y_mz, "y_max_m": 0.0},
        "fibre_width_m": d_f, "matrix_width_m": d_m, "elements_across_fibre": nf, "elements_across_matrix": nm,
        "element_size_along_fibre_m": (u[1] - u[0]) / cos_f, "line_family": "vertical" if vertical else "horizontal",
        "min_element_size_m": float(min_element_size(mesh)), "n_degenerate": int(np.sum(q[:, 3] == q[:, 2])),
    }
    return mesh


def _normalise(row):
    out = []
    for k in row:
        if not out or out[-1] != k:
            out.append(k)
    if len(out) > 1 and out[0] == out[-1]:
        out.pop()
    while len(out) < 4:
        out.append(out[-1])
    return out


def _quad_area(x, y, q):
    xs, ys = x[q], y[q]
    return 0.5 * np.sum(xs * np.roll(ys, -1, axis=1) - np.roll(xs, -1, axis=1) * ys, axis=1)


def min_element_size(mesh: Mesh) -> float:
    """Smallest characteristic length: area / longest diagonal (LS-DYNA's quad length)."""
    if mesh.n_elems == 0:
        return 0.0
    xs, ys = mesh.x[mesh.quads], mesh.y[mesh.quads]
    area = np.abs(_quad_area(mesh.x, mesh.y, mesh.quads))
    d1 = np.hypot(xs[:, 2] - xs[:, 0], ys[:, 2] - ys[:, 0])
    d2 = np.hypot(xs[:, 3] - xs[:, 1], ys[:, 3] - ys[:, 1])
    return float(np.min(area / np.maximum(d1, d2)))
