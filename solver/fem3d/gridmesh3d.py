"""Structured box meshes of hexahedra for tests, verification and benchmarks.

``box_mesh(nx, ny, nz, lx, ly, lz)`` fills the box [x0, x0 + lx] x [y0, y0 + ly] x [z0, z0 + lz]
with nx x ny x nz equal hexahedra; node (i, j, k) has the id i + (nx + 1) (j + (ny + 1) k) and an
element's nodes follow :mod:`.hex8`'s numbering (the face k counter-clockwise, then the face k + 1).
``perturb`` moves every interior node by a uniform random offset of up to that fraction of the
local element size along each axis (boundary nodes stay on the box's faces): a distorted mesh.
:func:`split_box_mesh` stacks two such boxes with duplicated nodes on the plane between them,
joined by cohesive elements over part of it (the rest a pre-crack): DCB and ENF specimens.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class HexMesh:
    """Nodes and hexahedra, the part every mesh of this module has."""

    X: np.ndarray  # (3, n) node coordinates [m]
    hexes: np.ndarray  # (ne, 8) int32

    @property
    def n_nodes(self) -> int:
        return self.X.shape[1]

    @property
    def n_elems(self) -> int:
        return self.hexes.shape[0]


@dataclass
class BoxMesh(HexMesh):
    shape: tuple  # (nx, ny, nz)

    def node(self, i, j, k):
        nx, ny, _ = self.shape
        return np.asarray(i) + (nx + 1) * (np.asarray(j) + (ny + 1) * np.asarray(k))


def box_mesh(nx: int, ny: int, nz: int, lx: float, ly: float, lz: float, origin=(0.0, 0.0, 0.0),
             perturb: float = 0.0, seed: int = 0) -> BoxMesh:
    """nx x ny x nz hexahedra filling a box (module docstring)."""
    if min(nx, ny, nz) < 1:
        raise ValueError(f"nx, ny, nz = {nx}, {ny}, {nz}: each must be >= 1")
    if not 0.0 <= perturb < 0.5:
        raise ValueError(f"perturb = {perturb}: must be in [0, 0.5)")
    xs = origin[0] + np.linspace(0.0, lx, nx + 1)
    ys = origin[1] + np.linspace(0.0, ly, ny + 1)
    zs = origin[2] + np.linspace(0.0, lz, nz + 1)
    Z, Y, Xg = np.meshgrid(zs, ys, xs, indexing="ij")  # (nz+1, ny+1, nx+1): id = i + (nx+1)(j + (ny+1)k)
    X = np.vstack([Xg.ravel(), Y.ravel(), Z.ravel()])
    if perturb > 0:
        rng = np.random.default_rng(seed)
        K, J, I = np.meshgrid(np.arange(nz + 1), np.arange(ny + 1), np.arange(nx + 1), indexing="ij")
        h = np.array([lx / nx, ly / ny, lz / nz])[:, None]
        dx = rng.uniform(-perturb, perturb, X.shape) * h
        for d, (idx, n) in enumerate(((I, nx), (J, ny), (K, nz))):
            free = ((idx > 0) & (idx < n)).ravel()
            dx[d, ~free] = 0.0  # a boundary node stays on its face (it may slide along it)
        X = X + dx
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    i, j, k = i.transpose(2, 1, 0).ravel(), j.transpose(2, 1, 0).ravel(), k.transpose(2, 1, 0).ravel()

    def nid(a, b, c):
        return a + (nx + 1) * (b + (ny + 1) * c)

    hexes = np.stack([nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                      nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)],
                     axis=1).astype(np.int32)
    return BoxMesh(np.ascontiguousarray(X), hexes, (nx, ny, nz))


@dataclass
class SplitBoxMesh(HexMesh):
    """Two boxes, one on the other, with duplicated nodes on the plane z = z0 between them, joined by
    cohesive elements (:mod:`.cohesive3d`) over part of it: see :func:`split_box_mesh` (hexes: the
    lower block's first)."""

    cohesive: np.ndarray  # (nc, 8) int32: a0..a3 on the lower block, b0..b3 the upper block's nodes at the same places
    precrack: np.ndarray  # (nc,) bool: the element lies on the pre-crack (only when asked for: contact there)
    lower: BoxMesh
    upper: BoxMesh
    n_lower: int  # the upper block's node ids start here

    @property
    def n_cohesive(self) -> int:
        return self.cohesive.shape[0]

    def lower_node(self, i, j, k):
        return self.lower.node(i, j, k)

    def upper_node(self, i, j, k):
        return self.n_lower + self.upper.node(i, j, k)


def split_box_mesh(nx: int, ny: int, nz_lower: int, nz_upper: int, lx: float, ly: float, h_lower: float, h_upper: float,
                   bonded=None, precrack_contact: bool = False, origin=(0.0, 0.0, 0.0)) -> SplitBoxMesh:
    """A box [x0, x0 + lx] x [y0, y0 + ly] x [z0 - h_lower, z0 + h_upper] split by the plane z = z0 into two
    blocks (nx x ny x nz_lower and nx x ny x nz_upper hexahedra, each numbered as :func:`box_mesh`), whose
    nodes on the plane are duplicated and joined by cohesive elements over the faces whose centre lies in
    ``bonded`` = (x_start, x_end) (default: all); the rest of the plane is open (a pre-crack). With
    ``precrack_contact`` the pre-crack's faces get cohesive elements too, flagged in ``precrack``: started
    fully damaged they only keep the faces from interpenetrating (the end-notched flexure's crack faces).
    Each element's a-face goes round counter-clockwise seen from +z, so its normal points from the lower
    block (side A) into the upper (side B)."""
    x0, y0, z0 = origin
    lo = box_mesh(nx, ny, nz_lower, lx, ly, h_lower, origin=(x0, y0, z0 - h_lower))
    up = box_mesh(nx, ny, nz_upper, lx, ly, h_upper, origin=(x0, y0, z0))
    nlo = lo.n_nodes
    X = np.hstack([lo.X, up.X])
    hexes = np.vstack([lo.hexes, up.hexes + nlo]).astype(np.int32)
    if bonded is None:
        bonded = (x0 - 1.0 - abs(lx), x0 + 1.0 + 2 * abs(lx))
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    xc = x0 + (i + 0.5) * lx / nx
    on = (xc >= bonded[0]) & (xc <= bonded[1])
    keep = np.ones_like(on) if precrack_contact else on
    i, j, on = i[keep], j[keep], on[keep]
    ia = [lo.node(i, j, nz_lower), lo.node(i + 1, j, nz_lower), lo.node(i + 1, j + 1, nz_lower), lo.node(i, j + 1, nz_lower)]
    ib = [nlo + up.node(i, j, 0), nlo + up.node(i + 1, j, 0), nlo + up.node(i + 1, j + 1, 0), nlo + up.node(i, j + 1, 0)]
    coh = np.stack(ia + ib, axis=1).astype(np.int32).reshape(-1, 8)
    return SplitBoxMesh(np.ascontiguousarray(X), hexes, coh, ~on, lo, up, nlo)
