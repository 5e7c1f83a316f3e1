"""Small structured meshes for verification and benchmarks (the cutting mesher is solver.mesher).

``layered_mesh`` stacks horizontal layers of rectangular quads (each with its material and
fibre angle); the nodes on an interface between two layers are duplicated and joined by
cohesive elements where ``cohesive_x`` says (elsewhere the layers are free: a crack).
``rect_mesh`` is one layer.
"""

from __future__ import annotations

import numpy as np

from ..mesh import Mesh


def layered_mesh(x_edges, layers, cohesive_x=None, tie=False) -> Mesh:
    """Layers stacked bottom to top.

    x_edges: node x coordinates (shared by all layers). layers: list of (y_edges, material,
    fibre_angle_rad). cohesive_x: (x_lo, x_hi) range of the interfaces joined by cohesive
    elements (default: all). tie: share the interface nodes instead (no cohesive, no crack).
    Nothing is fixed; set ``mesh.fixed_x/fixed_y`` afterwards.
    """
    x_edges = np.asarray(x_edges, float)
    nx = x_edges.size - 1
    xs, ys, quads, mats, angs = [], [], [], [], []
    coh, coh_el = [], []
    n_off = 0
    e_off = 0
    prev_top = None  # (node ids of the previous layer's top row, its element ids along x)
    lo, hi = (-np.inf, np.inf) if cohesive_x is None else cohesive_x
    for li, (y_edges, mat, ang) in enumerate(layers):
        y_edges = np.asarray(y_edges, float)
        ny = y_edges.size - 1
        X, Y = np.meshgrid(x_edges, y_edges)  # (ny+1, nx+1)
        ids = np.arange((ny + 1) * (nx + 1)).reshape(ny + 1, nx + 1) + n_off
        if tie and prev_top is not None:
            ids = ids - (nx + 1)
            ids[0] = prev_top[0]
            xs.append(X[1:].ravel())
            ys.append(Y[1:].ravel())
            n_new = ny * (nx + 1)
        else:
            xs.append(X.ravel())
            ys.append(Y.ravel())
            n_new = (ny + 1) * (nx + 1)
        q = np.stack([ids[:-1, :-1], ids[:-1, 1:], ids[1:, 1:], ids[1:, :-1]], axis=-1).reshape(-1, 4)
        el = np.arange(ny * nx).reshape(ny, nx) + e_off
        if not tie and prev_top is not None:
            top_ids, top_el = prev_top
            bot_ids = ids[0]
            for i in range(nx):
                xm = 0.5 * (x_edges[i] + x_edges[i + 1])
                if lo <= xm <= hi:
                    coh.append([top_ids[i], top_ids[i + 1], bot_ids[i], bot_ids[i + 1]])
                    coh_el.append([top_el[i], el[0, i]])
        quads.append(q)
        mats.append(np.full(q.shape[0], mat, np.int8))
        angs.append(np.full(q.shape[0], ang, float))
        prev_top = (ids[-1].copy(), el[-1].copy())
        n_off += n_new
        e_off += q.shape[0]
    x = np.concatenate(xs)
    y = np.concatenate(ys)
    n = x.size
    return Mesh(x=x, y=y, quads=np.concatenate(quads).astype(np.int32), material=np.concatenate(mats),
                fibre_angle=np.concatenate(angs), fixed_x=np.zeros(n, bool), fixed_y=np.zeros(n, bool),
                cohesive=np.array(coh, np.int32).reshape(-1, 4), cohesive_elems=np.array(coh_el, np.int32).reshape(-1, 2),
                info={"generator": "solver.fem.gridmesh.layered_mesh"})


def rect_mesh(nx, ny, length, height, material=1, angle=0.0, x0=0.0, y0=0.0) -> Mesh:
    """A length x height rectangle of nx x ny equal quads, one material and fibre angle."""
    return layered_mesh(np.linspace(x0, x0 + length, nx + 1), [(np.linspace(y0, y0 + height, ny + 1), material, angle)])


def strip_mesh(nx, n_fibres, length, fibre_width, matrix_width, across_fibre=3, across_matrix=1, cohesive=True) -> Mesh:
    """Alternating matrix / fibre strips along x (fibres at 0 deg), cohesive on every interface.

    The material mix of the cutting scene's micro zone; used by the benchmark.
    """
    layers = []
    y = 0.0
    for k in range(n_fibres):
        layers.append((np.linspace(y, y + matrix_width, across_matrix + 1), 1, 0.0))
        y += matrix_width
        layers.append((np.linspace(y, y + fibre_width, across_fibre + 1), 0, 0.0))
        y += fibre_width
    return layered_mesh(np.linspace(0.0, length, nx + 1), layers, tie=not cohesive)
