"""The 3D micro-mechanical strip: cylindrical fibres in matrix, cohesive fibre-matrix surfaces, EHM around.

Geometry (the 2D workpiece's frame, :mod:`solver.mesher`, with a width): x in [0, L] along the cut,
y in [-H, 0] (top free), z in [0, W] across the strip, W = ``pitches`` fibre pitches; the strip's sides
z = 0 and z = W are symmetry planes of the laminate.

Fibres in a square array: diameter d_f and volume fraction V_f give the pitch p = d_f sqrt(pi / (4 V_f))
(p = 8.58 um for the paper's 7.5 um at 60 %). Each fibre sits in a square cell p x p, meshed in its cross-section as an
O-grid (e.g. Hughes, "The Finite Element Method", 1987, ch. 3 for the mapped-mesh idea; the usual layout of
fibre-in-matrix unit cells):

* a core square of half-width ``core`` x r, (2 n) x (2 n) quadrilaterals (n = ``n_quarter``);
* the fibre ring from the core's perimeter to the fibre's surface, ``n_fibre_rings`` layers;
* the matrix ring from the fibre's surface to the cell's square boundary, ``n_matrix_rings`` layers;

so 8 n quadrilaterals go round the fibre. Perimeter points are equally spaced along each square (p / (2 n)
on the cell's boundary, so neighbouring cells and structured EHM blocks share nodes); the fibre surface's
points lie on the rays through them. The surface is an 8 n-gon scaled so that its area is pi r^2 (the fibre
volume fraction is exact at any n). Fibre-side and matrix-side nodes of the surface are distinct,
joined by 8-node cohesive elements (:mod:`.cohesive3d`; side A the fibre, its normal pointing into the
matrix).

The cross-section is extruded along the fibre (axial element size ``h``, the paper's 2 um):

* 0 degrees (fibres along x): cells stacked down from the free surface over the micro zone's depth
  (y in [-mz_depth, 0], whole cells), W / p across z, extruded over x in [0, L]; below the micro zone
  the EHM is a structured block (the cells' axial and z nodes, y graded coarser towards -H).
* 90 degrees (fibres along y, normal to the cut surface): cells side by side along x over the micro
  zone x in [x_ms, L] (whole cells ending at L), extruded from y = 0 down to -mz_depth as fibre and
  matrix, then on to -H as EHM (the same O-grid, graded coarser); ahead of the micro zone (x < x_ms)
  a structured EHM block sharing the cells' y and z nodes.

Hexahedra follow :mod:`.hex8`'s numbering (a counter-clockwise face, then the face one level up), all
with positive volume. Material ids as the 2D mesh (:mod:`solver.mesh`: FIBRE, MATRIX, EHM).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..mesh import EHM, FIBRE, MATRIX


@dataclass(frozen=True)
class StripSpec:
    """What the strip is built from (SI): the fibre angle (0 or 90 degrees), the workpiece L x H, the
    number of fibre pitches across the strip, the fibre's diameter and volume fraction, the axial element
    size h, the O-grid's divisions, the micro zone (depth from the free surface, start along x at 90
    degrees) and the EHM's grading."""

    theta_deg: float
    L: float
    H: float
    d_f: float = 7.5e-6
    vf: float = 0.6
    h: float = 2e-6
    pitches: int = 1
    mz_depth: float = 160e-6
    x_ms: float = 0.0
    n_quarter: int = 1
    n_fibre_rings: int = 1
    n_matrix_rings: int = 1
    core: float = 0.5
    growth: float = 1.3
    h_max: float = 20e-6

    @property
    def pitch(self) -> float:
        return self.d_f * math.sqrt(math.pi / (4.0 * self.vf))

    @property
    def width(self) -> float:
        return self.pitches * self.pitch


@dataclass
class StripMesh3D:
    X: np.ndarray  # (3, n) node coordinates [m]
    hexes: np.ndarray  # (ne, 8) int32
    material: np.ndarray  # (ne,) int8: FIBRE, MATRIX, EHM
    fibre_id: np.ndarray  # (ne,) int32: the fibre (cell) an element belongs to, -1 in the EHM
    cohesive: np.ndarray  # (nc, 8) int32: a0..a3 fibre side, b0..b3 matrix side
    cohesive_elems: np.ndarray  # (nc, 2) int64: the fibre and the matrix hexahedron on either side of each
    direction: np.ndarray  # (3,) unit fibre direction
    info: dict = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        return int(self.X.shape[1])

    @property
    def n_elems(self) -> int:
        return int(self.hexes.shape[0])

    @property
    def n_cohesive(self) -> int:
        return int(self.cohesive.shape[0])

    @property
    def x(self) -> np.ndarray:
        return self.X[0]

    @property
    def y(self) -> np.ndarray:
        return self.X[1]

    @property
    def elements(self) -> np.ndarray:
        """The elements' node ids (the hexahedra)."""
        return self.hexes

    def series(self) -> dict:
        """The reference mesh as a run stores it beside its frames."""
        return {"x": self.X[0], "y": self.X[1], "z": self.X[2], "hexes": self.hexes, "material": self.material,
                "cohesive": self.cohesive, "fibre_pitch": np.array(self.info["pitch_m"])}

    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.X, self.hexes, self.material, self.fibre_id, self.cohesive, self.cohesive_elems))

    def nodes_on(self, axis: int, value: float, tol: float | None = None) -> np.ndarray:
        """Ids of the nodes on the plane X[axis] = value (e.g. the symmetry sides z = 0 and z = W)."""
        tol = 1e-9 * float(np.ptp(self.X)) if tol is None else tol
        return np.flatnonzero(np.abs(self.X[axis] - value) <= tol)


# --------------------------------------------------------------------------- the cross-section

def _square_perimeter(half: float, n: int) -> np.ndarray:
    """8 n points equally spaced (half / n) round the square [-half, half]^2, counter-clockwise from (half, 0)."""
    t = np.arange(8 * n) / n  # arc length in units of half / n ... in units of half
    pts = np.empty((8 * n, 2))
    for k, s in enumerate(t):
        s = (s + 1.0) % 8.0  # arc length from the corner (half, -half), going up the right side
        if s < 2.0:
            pts[k] = (half, -half + s * half)
        elif s < 4.0:
            pts[k] = (half - (s - 2.0) * half, half)
        elif s < 6.0:
            pts[k] = (-half, half - (s - 4.0) * half)
        else:
            pts[k] = (-half + (s - 6.0) * half, -half)
    return pts


@dataclass
class Section:
    """The O-grid of one cell, centred on the fibre: points (m, 2), quads (q, 4) counter-clockwise,
    their material, the fibre-side and matrix-side node ids of the fibre surface (8 n each, in order) and
    the ids of the cell's boundary points (8 n, in order from (p/2, 0))."""

    pts: np.ndarray
    quads: np.ndarray
    material: np.ndarray
    surf_fibre: np.ndarray
    surf_matrix: np.ndarray
    boundary: np.ndarray
    surf_quads: np.ndarray  # (8 n, 2): the fibre and the matrix quad on either side of each surface segment


def cell_section(pitch: float, d_f: float, n: int = 1, nf: int = 1, nm: int = 1, core: float = 0.5) -> Section:
    """The O-grid cross-section of one fibre cell (module docstring)."""
    if n < 1 or nf < 1 or nm < 1:
        raise ValueError(f"n_quarter, n_fibre_rings, n_matrix_rings = {n}, {nf}, {nm}: each must be >= 1")
    r = 0.5 * d_f
    if not (0.0 < core < 1.0) or r >= 0.5 * pitch:
        raise ValueError(f"core = {core}, radius {r:.3g} m, pitch {pitch:.3g} m: need 0 < core < 1 and the fibre inside its cell")
    half_c, half_p = core * r, 0.5 * pitch
    pts: list = []
    quads: list = []
    mats: list = []
    # core grid
    g = np.linspace(-half_c, half_c, 2 * n + 1)
    core_id = np.arange((2 * n + 1) ** 2).reshape(2 * n + 1, 2 * n + 1)  # [j (v), i (u)]
    for j in range(2 * n + 1):
        for i in range(2 * n + 1):
            pts.append((g[i], g[j]))
    for j in range(2 * n):
        for i in range(2 * n):
            quads.append((core_id[j, i], core_id[j, i + 1], core_id[j + 1, i + 1], core_id[j + 1, i]))
            mats.append(FIBRE)
    # the core's perimeter as grid ids (same order as _square_perimeter)
    per = _square_perimeter(half_c, n)
    step = half_c / n
    per_ids = np.array([core_id[int(round((pv + half_c) / step)), int(round((pu + half_c) / step))] for pu, pv in per])
    # the fibre surface: rays through the cell boundary's points, an 8n-gon of area pi r^2
    outer = _square_perimeter(half_p, n)
    ang = np.arctan2(outer[:, 1], outer[:, 0])
    ring = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    poly_area = 0.5 * abs(np.sum(ring[:, 0] * np.roll(ring[:, 1], -1) - np.roll(ring[:, 0], -1) * ring[:, 1]))
    surf = ring * r * math.sqrt(math.pi / poly_area)
    if np.any(np.abs(surf).max(axis=1) >= half_p):
        raise ValueError(f"fibre diameter {d_f:.3g} m in pitch {pitch:.3g} m: the {8 * n}-gon leaves its cell; use more points round the fibre")

    def ring_layers(inner_ids, inner_xy, outer_xy, layers, mat, new_inner):
        """Layers of quads from the inner loop (ids, points) to the outer points; returns the outer loop's ids."""
        prev = inner_ids
        if new_inner:
            prev = np.arange(len(pts), len(pts) + len(inner_xy))
            pts.extend(map(tuple, inner_xy))
        for lay in range(1, layers + 1):
            t = lay / layers
            cur = np.arange(len(pts), len(pts) + len(inner_xy))
            pts.extend(map(tuple, (1 - t) * inner_xy + t * outer_xy))
            m = len(inner_xy)
            for k in range(m):
                quads.append((prev[k], cur[k], cur[(k + 1) % m], prev[(k + 1) % m]))
                mats.append(mat)
            prev = cur
        return prev

    surf_f = ring_layers(per_ids, per, surf, nf, FIBRE, False)
    surf_m_start = len(pts)
    bnd = ring_layers(None, surf, outer, nm, MATRIX, True)
    surf_m = np.arange(surf_m_start, surf_m_start + 8 * n)
    P = np.array(pts)
    Q = np.array(quads, dtype=np.int64)
    # counter-clockwise (positive signed area) for every quad
    a = P[Q]
    area = 0.5 * np.sum(a[:, :, 0] * np.roll(a[:, :, 1], -1, axis=1) - np.roll(a[:, :, 0], -1, axis=1) * a[:, :, 1], axis=1)
    Q[area < 0] = Q[area < 0][:, ::-1]
    seg = np.arange(8 * n)
    core_quads = 4 * n * n
    surf_quads = np.stack([core_quads + (nf - 1) * 8 * n + seg, core_quads + nf * 8 * n + seg], axis=1)
    return Section(P, Q, np.array(mats, np.int8), np.asarray(surf_f), surf_m, np.asarray(bnd), surf_quads)


# --------------------------------------------------------------------------- extrusion and assembly

def _graded_levels(start: float, stop: float, h0: float, growth: float, hmax: float) -> np.ndarray:
    """Points from start to stop (start excluded, stop included), sizes growing from h0 by ``growth`` up to hmax."""
    out, pos, h = [], start, h0
    sign = 1.0 if stop > start else -1.0
    while sign * (stop - pos) > 1e-12 * max(abs(stop), abs(start), 1e-9):
        h = min(h * growth, hmax)
        pos = stop if sign * (stop - pos) < 1.5 * h else pos + sign * h
        out.append(pos)
    return np.array(out)


class _Builder:
    """Collects nodes and hexahedra; nodes flagged mergeable are joined with coincident mergeable nodes."""

    def __init__(self, tol: float):
        self.tol = tol
        self.X: list = []
        self.merge: list = []
        self.hexes: list = []
        self.mat: list = []
        self.fib: list = []
        self.coh: list = []
        self.coh_elems: list = []
        self.n_elems = 0

    def add_nodes(self, X: np.ndarray, mergeable: np.ndarray) -> int:
        off = sum(len(x) for x in self.X)
        self.X.append(X.T)
        self.merge.append(mergeable)
        return off

    def finish(self):
        X = np.vstack(self.X).T
        mergeable = np.concatenate(self.merge)
        n = X.shape[1]
        new = np.arange(n)
        ids = np.flatnonzero(mergeable)
        key = np.round(X[:, ids] / self.tol).astype(np.int64)
        _, first, inv = np.unique(key, axis=1, return_index=True, return_inverse=True)
        new[ids] = ids[first][inv.ravel()]
        keep = np.unique(new)
        renum = -np.ones(n, np.int64)
        renum[keep] = np.arange(keep.size)
        final = renum[new]
        hexes = final[np.vstack(self.hexes)].astype(np.int32)
        coh = final[np.vstack(self.coh)].astype(np.int32) if self.coh else np.zeros((0, 8), np.int32)
        coh_elems = np.vstack(self.coh_elems) if self.coh_elems else np.zeros((0, 2), np.int64)
        return (np.ascontiguousarray(X[:, keep]), hexes, np.concatenate(self.mat).astype(np.int8),
                np.concatenate(self.fib).astype(np.int32), coh, coh_elems)


def _extrude(b: _Builder, sec: Section, to3d, centre, levels, level_mat, fibre_index, tol):
    """One cell extruded through ``levels`` (axial coordinates, ascending); ``to3d(u, v, a)`` maps the
    section's (u, v) and the axial coordinate to (x, y, z) keeping the orientation; ``level_mat[k]`` is
    None (fibre and matrix) or EHM for the segment [levels[k], levels[k + 1]]."""
    m = sec.pts.shape[0]
    K = len(levels)
    U = np.repeat((sec.pts[:, 0] + centre[0])[None, :], K, 0).ravel()
    V = np.repeat((sec.pts[:, 1] + centre[1])[None, :], K, 0).ravel()
    A = np.repeat(np.asarray(levels)[:, None], m, 1).ravel()
    X = to3d(U, V, A)
    # every node may merge with a neighbour (cells, EHM) except the fibre-side surface nodes, which
    # stay apart from the matrix side's where a cohesive element joins them; in EHM segments both sides merge
    mergeable = np.ones(m, bool)
    mergeable[sec.surf_fibre] = False
    merge = np.tile(mergeable, (K, 1))
    ehm_level = np.array([mt == EHM for mt in level_mat] + [False])
    for k in range(K):
        if ehm_level[k] or (k > 0 and ehm_level[k - 1]):
            merge[k, sec.surf_fibre] = True  # touches an EHM segment: bonded to the matrix side there
    off = b.add_nodes(X, merge.ravel())
    nid = lambda k, j: off + k * m + j  # noqa: E731
    q = sec.quads
    for k in range(K - 1):
        b.hexes.append(np.concatenate([nid(k, q), nid(k + 1, q)], axis=1))
        first = b.n_elems
        b.n_elems += len(q)
        if level_mat[k] == EHM:
            b.mat.append(np.full(len(q), EHM))
            b.fib.append(np.full(len(q), -1))
        else:
            b.mat.append(sec.material)
            b.fib.append(np.full(len(q), fibre_index))
            sf, sm = sec.surf_fibre, sec.surf_matrix
            s1f, s1m = np.roll(sf, -1), np.roll(sm, -1)
            b.coh.append(np.stack([nid(k, sf), nid(k, s1f), nid(k + 1, s1f), nid(k + 1, sf),
                                   nid(k, sm), nid(k, s1m), nid(k + 1, s1m), nid(k + 1, sm)], axis=1))
            b.coh_elems.append(first + sec.surf_quads)


def _box(b: _Builder, xs, ys, zs):
    """A structured EHM block on the grid xs x ys x zs (ascending)."""
    nx, ny, nz = len(xs) - 1, len(ys) - 1, len(zs) - 1
    Z, Y, Xg = np.meshgrid(zs, ys, xs, indexing="ij")
    off = b.add_nodes(np.vstack([Xg.ravel(), Y.ravel(), Z.ravel()]), np.ones(Xg.size, bool))
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    i, j, k = i.ravel(), j.ravel(), k.ravel()
    nid = lambda a, c, d: off + a + (nx + 1) * (c + (ny + 1) * d)  # noqa: E731
    b.hexes.append(np.stack([nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                             nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)], axis=1))
    b.n_elems += nx * ny * nz
    b.mat.append(np.full(nx * ny * nz, EHM))
    b.fib.append(np.full(nx * ny * nz, -1))


def _columns(spec: StripSpec) -> int:
    """Fibre columns of the 90-degree strip: whole cells ending at x = L, covering [x_ms, L] as far as the
    workpiece's length allows."""
    p = spec.pitch
    if spec.L < p * (1 - 1e-9):
        raise ValueError(f"workpiece length {spec.L * 1e6:.4g} um is shorter than one fibre pitch {p * 1e6:.4g} um")
    return max(1, min(int(math.ceil((spec.L - spec.x_ms) / p - 1e-9)), int(math.floor(spec.L / p + 1e-9))))


def _axial(lo: float, hi: float, h: float) -> np.ndarray:
    n = max(1, int(round((hi - lo) / h)))
    return np.linspace(lo, hi, n + 1)


def build_strip(spec: StripSpec) -> StripMesh3D:
    """Mesh the 3D strip (module docstring)."""
    p = spec.pitch
    n = spec.n_quarter
    sec = cell_section(p, spec.d_f, n, spec.n_fibre_rings, spec.n_matrix_rings, spec.core)
    tol = 1e-6 * p
    b = _Builder(tol)
    theta = float(spec.theta_deg) % 180.0
    zs = np.linspace(0.0, spec.width, 2 * n * spec.pitches + 1)
    if abs(theta) < 1e-9:
        n_rows = max(1, int(math.ceil(spec.mz_depth / p - 1e-9)))
        y_mz = -n_rows * p
        if -y_mz >= spec.H:
            raise ValueError(f"micro zone {n_rows} fibre pitches deep ({-y_mz * 1e6:.1f} um) reaches the workpiece's height {spec.H * 1e6:.1f} um")
        xs = _axial(0.0, spec.L, spec.h)
        # fibres along x: section (u, v) = (y, z), axial a = x; (y, z, x) is right-handed
        to3d = lambda u, v, a: np.vstack([a, u, v])  # noqa: E731
        fidx = 0
        for row in range(n_rows):
            for col in range(spec.pitches):
                _extrude(b, sec, to3d, (-(row + 0.5) * p, (col + 0.5) * p), xs, [None] * (len(xs) - 1), fidx, tol)
                fidx += 1
        ys = np.concatenate([[y_mz], _graded_levels(y_mz, -spec.H, p / (2 * n), spec.growth, spec.h_max)])[::-1]
        _box(b, xs, ys, zs)
        direction = np.array([1.0, 0.0, 0.0])
        info = dict(fibres=fidx, rows=n_rows, micro_zone_bottom_m=y_mz)
    elif abs(theta - 90.0) < 1e-9:
        n_cols = _columns(spec)
        x_ms = max(spec.L - n_cols * p, 0.0)
        y_top = _axial(-spec.mz_depth, 0.0, spec.h)
        y_low = _graded_levels(-spec.mz_depth, -spec.H, y_top[1] - y_top[0], spec.growth, spec.h_max)[::-1]
        ys = np.concatenate([y_low, y_top])
        mats = [EHM] * len(y_low) + [None] * (len(y_top) - 1)
        # fibres along y: section (u, v) = (z, x), axial a = y; (z, x, y) is right-handed
        to3d = lambda u, v, a: np.vstack([v, a, u])  # noqa: E731
        fidx = 0
        for col in range(n_cols):
            for row in range(spec.pitches):
                _extrude(b, sec, to3d, ((row + 0.5) * p, x_ms + (col + 0.5) * p), ys, mats, fidx, tol)
                fidx += 1
        if x_ms > 0:
            xs = np.concatenate([[x_ms], _graded_levels(x_ms, 0.0, p / (2 * n), spec.growth, spec.h_max)])[::-1]
            _box(b, xs, ys, zs)
        direction = np.array([0.0, 1.0, 0.0])
        info = dict(fibres=fidx, columns=n_cols, micro_zone_start_m=x_ms)
    else:
        raise ValueError(f"fibre angle {spec.theta_deg} deg: the 3D strip is built for 0 and 90 degrees")
    X, hexes, mat, fib, coh, coh_elems = b.finish()
    info.update(pitch_m=p, width_m=spec.width, n_quarter=n, elements_round_fibre=8 * n)
    return StripMesh3D(X, hexes, mat, fib, coh, coh_elems, direction, info)


#: the six faces of a hexahedron (:mod:`.hex8` numbering), each counter-clockwise seen from outside
HEX_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))


def faces_on(X: np.ndarray, hexes: np.ndarray, axis: int, value: float, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """The element faces lying on the plane X[axis] = value: (node ids (k, 4), the element of each (k,)).

    A face inside the body shows once per element on either side."""
    on = np.abs(X[axis] - value) <= tol
    quads, elems = [], []
    for f in HEX_FACES:
        sel = np.all(on[hexes[:, list(f)]], axis=1)
        quads.append(hexes[sel][:, list(f)])
        elems.append(np.flatnonzero(sel))
    return np.vstack(quads), np.concatenate(elems)


def side_section(X: np.ndarray, hexes: np.ndarray, pitch: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The faces on the plane z = p/2 through the axes of the first fibres across the strip (a node plane of
    the O-grids and of the EHM blocks): (node ids (k, 4), the element of each, the plane's z): the side view
    of a 3D run's frames."""
    zc = 0.5 * float(pitch)
    quads, elems = faces_on(X, hexes, 2, zc, 1e-9 * float(np.ptp(X)))
    return quads, elems, zc


def mid_section_value(mesh: StripMesh3D) -> tuple[int, float]:
    """(axis, coordinate) of the node level nearest the middle of the fibres' length: where a cross-section
    shows the O-grids."""
    axis = int(np.argmax(np.abs(mesh.direction)))
    fib = mesh.hexes[mesh.fibre_id >= 0]
    levels = np.unique(mesh.X[axis, fib])
    mid = 0.5 * (levels.min() + levels.max())
    return axis, float(levels[np.argmin(np.abs(levels - mid))])


# --------------------------------------------------------------------------- from a scene

def strip_spec(si) -> StripSpec:
    """The strip of an SI scene (``scene.si()``): the 2D workpiece's sizes (:func:`solver.mesher.strip_geometry`:
    length, height, micro zone) with the 3D fields ``strip_pitches`` and ``elements_round_fibre``."""
    from ..mesher import strip_geometry

    g = strip_geometry(si)
    n_round = int(getattr(si, "elements_round_fibre", 8))
    h = float(si.element_size)
    return StripSpec(theta_deg=math.degrees(g.theta), L=g.L, H=g.H, d_f=g.d_f, vf=float(si.fibre_volume_fraction), h=h,
                     pitches=int(getattr(si, "strip_pitches", 1)), mz_depth=g.mz_depth, x_ms=g.x_ms,
                     n_quarter=max(1, n_round // 8), h_max=max(4.0 * h, 20e-6))


def build_strip_mesh(si) -> StripMesh3D:
    """The 3D strip of an SI scene (:func:`strip_spec`, :func:`build_strip`)."""
    return build_strip(strip_spec(si))


def strip_counts(spec: StripSpec) -> tuple[int, int]:
    """(hexahedra, cohesive elements) :func:`build_strip` makes, counted without building the mesh."""
    n, nf, nm = spec.n_quarter, spec.n_fibre_rings, spec.n_matrix_rings
    per_level = 4 * n * n + 8 * n * (nf + nm)
    p = spec.pitch
    nz = 2 * n * spec.pitches
    theta = float(spec.theta_deg) % 180.0
    if abs(theta) < 1e-9:
        rows = max(1, int(math.ceil(spec.mz_depth / p - 1e-9)))
        nx = max(1, int(round(spec.L / spec.h)))
        ny = len(_graded_levels(-rows * p, -spec.H, p / (2 * n), spec.growth, spec.h_max))
        cells = rows * spec.pitches
        return cells * per_level * nx + nx * ny * nz, cells * 8 * n * nx
    cols = _columns(spec)
    n_top = max(1, int(round(spec.mz_depth / spec.h)))
    h_top = spec.mz_depth / n_top
    n_low = len(_graded_levels(-spec.mz_depth, -spec.H, h_top, spec.growth, spec.h_max))
    cells = cols * spec.pitches
    x_ms = max(spec.L - cols * p, 0.0)
    nx = len(_graded_levels(x_ms, 0.0, p / (2 * n), spec.growth, spec.h_max)) if x_ms > 0 else 0
    return cells * per_level * (n_top + n_low) + nx * (n_top + n_low) * nz, cells * 8 * n * n_top
