"""Contact: the rigid tool against nodes/particles, and fragments against the workpiece.

Tool contact (contract in the engine's chunk loop): node-to-rigid-surface penalty with the
exact signed distance of :func:`solver.tool.tool_sdf`, regularised Coulomb friction.

Fragment contact: pieces separated by deleted elements must not pass through each other.
Node-to-exposed-edge penalty (the classic node-to-segment scheme, e.g. Belytschko, Liu &
Moran, "Nonlinear Finite Elements for Continua and Structures", 2nd ed., sec. 10.4; penalty
form): every exposed boundary node is tested against the exposed boundary edges of *other*
parts of the mesh found through a uniform cell list of exposed edges (cell >= the longest
exposed edge; O(N) in the number of exposed nodes). The list is rebuilt when elements are
deleted and periodically as nodes move.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .tool import tool_sdf


@numba.njit(cache=True)
def tool_contact(px, py, vx, vy, mass, node_active, tool, k_pen, mu, fx, fy, out):
    """Penalty contact + regularised Coulomb friction between the rigid tool and nodes.

    For a node with signed distance sd < 0 (penetration g = -sd) and outward tool normal n:
        f_N = k_pen * g * n                                  (penalty, N/m per m width)
        v_t = (v - v_tool) - ((v - v_tool) . n) n            (slip velocity)
        f_T = -mu |f_N| v_t / sqrt(|v_t|^2 + eps^2)          (regularised Coulomb, |f_T| < mu |f_N|)
    with eps = 1e-3 |v_tool| + 1e-9 m/s (the regularisation velocity; Oden & Martins 1985).
    Forces are added to fx, fy. ``out[0:2]`` accumulate the reaction on the tool (minus the sum
    of the forces added), ``out[2]`` the deepest penetration [m], ``out[3]`` the frictional power
    -f_T . v_t [W/m] (>= 0). ``mass`` is accepted for the contract (unused by this penalty).
    """
    vtx = tool[2]
    vty = tool[3]
    eps = 1e-3 * math.sqrt(vtx * vtx + vty * vty) + 1e-9
    # quick reject: nodes farther than a bounding radius from the arc centre cannot touch
    # the (infinite) wedge only if they are on the outer side of both face lines; tool_sdf is
    # cheap enough that we test all active nodes (cost linear in their number).
    for i in range(px.shape[0]):
        if node_active[i] == 0:
            continue
        sd, nx, ny = tool_sdf(px[i], py[i], tool)
        if sd >= 0.0:
            continue
        g = -sd
        fn = k_pen * g
        fxi = fn * nx
        fyi = fn * ny
        rvx = vx[i] - vtx
        rvy = vy[i] - vty
        vn = rvx * nx + rvy * ny
        tx = rvx - vn * nx
        ty = rvy - vn * ny
        vt = math.sqrt(tx * tx + ty * ty)
        if mu > 0.0 and vt > 0.0:
            scale = mu * fn / math.sqrt(vt * vt + eps * eps)
            fxi -= scale * tx
            fyi -= scale * ty
            out[3] += scale * vt * vt
        fx[i] += fxi
        fy[i] += fyi
        out[0] -= fxi
        out[1] -= fyi
        if g > out[2]:
            out[2] = g


def contact_stiffness(node_mass_min: float, dt: float, factor: float = 1.0) -> float:
    """Penalty stiffness consistent with the explicit step: k = 0.1 m_min / dt^2 x factor.

    A node of mass m on a spring k is stable for dt < 2 sqrt(m/k); with k = 0.1 m/dt^2 the
    contact's own limit is 2 sqrt(10) dt ~ 6.3 dt, so contact never limits the step (the IWF
    mfree codes use alpha m / dt^2 with alpha ~ 0.1, SOLVER_NOTES.md 4).
    """
    return 0.1 * node_mass_min / (dt * dt) * factor


# ------------------------------------------------------------------------------ fragments
def boundary_edges(quads: np.ndarray, alive: np.ndarray) -> np.ndarray:
    """Edges of living quads not shared with another living quad: (n, 3) [node0, node1, elem].

    Edge direction follows the counter-clockwise quad, so the outward normal of edge
    (a -> b) is (dy, -dx)/|.|. Degenerate (zero-length) edges are skipped.
    """
    q = quads[alive.astype(bool)]
    ids = np.nonzero(alive)[0]
    a = q.reshape(-1)
    b = np.roll(q, -1, axis=1).reshape(-1)
    el = np.repeat(ids, 4)
    keep = a != b
    a, b, el = a[keep], b[keep], el[keep]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * (int(quads.max()) + 1 if quads.size else 1) + hi
    uniq, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    single = counts[inv] == 1
    return np.stack([a[single], b[single], el[single]], axis=1).astype(np.int32)


@numba.njit(cache=True)
def _build_cells(px, py, edges, x0, y0, cell, ncx, ncy, head, nxt):
    """Cell list of exposed edges by their midpoint (linked list: head per cell, nxt per edge)."""
    for c in range(head.shape[0]):
        head[c] = -1
    for e in range(edges.shape[0]):
        mx = 0.5 * (px[edges[e, 0]] + px[edges[e, 1]])
        my = 0.5 * (py[edges[e, 0]] + py[edges[e, 1]])
        cx = min(max(int((mx - x0) / cell), 0), ncx - 1)
        cy = min(max(int((my - y0) / cell), 0), ncy - 1)
        c = cy * ncx + cx
        nxt[e] = head[c]
        head[c] = e


@numba.njit(cache=True)
def fragment_contact(px, py, edges, part, nodes, node_part, x0, y0, cell, ncx, ncy, head, nxt,
                     k_pen, fx, fy, out):
    """Node-to-exposed-edge penalty between different parts (fragments) of the mesh.

    For every exposed node of part P, the exposed edges (a, b) of other parts in the 3 x 3
    cells around it are tested: with s = ((x - a) . (b - a)) / |b - a|^2 in [0, 1] and the gap
    g = (x - a) . n (n the outward normal of the edge's element), a node with -|b - a|/2 < g < 0
    is inside; the edge with the smallest |g| acts (a node in a corner is pushed out through
    the nearest face only): f = -k_pen g n on the node and minus the same on a and b in
    proportion (1 - s, s), so momentum is conserved (Belytschko, Liu & Moran 2014, sec. 10.4,
    penalty method). ``out[0]`` = max(out[0], deepest penetration [m]).
    """
    for k in range(nodes.shape[0]):
        i = nodes[k]
        pk = node_part[k]
        xi, yi = px[i], py[i]
        cx = int((xi - x0) / cell)
        cy = int((yi - y0) / cell)
        best_g = 0.0
        best_e = -1
        best_s = 0.0
        bnx = 0.0
        bny = 0.0
        for yy in range(max(cy - 1, 0), min(cy + 1, ncy - 1) + 1):
            for xx in range(max(cx - 1, 0), min(cx + 1, ncx - 1) + 1):
                e = head[yy * ncx + xx]
                while e >= 0:
                    a = edges[e, 0]
                    b = edges[e, 1]
                    if part[e] != pk and i != a and i != b:
                        ax, ay = px[a], py[a]
                        ex, ey = px[b] - ax, py[b] - ay
                        l2 = ex * ex + ey * ey
                        if l2 > 0.0:
                            dx, dy = xi - ax, yi - ay
                            s = (dx * ex + dy * ey) / l2
                            if 0.0 <= s <= 1.0:
                                ln = math.sqrt(l2)
                                nx, ny = ey / ln, -ex / ln
                                g = dx * nx + dy * ny
                                if g < 0.0 and g > -0.5 * ln and (best_e < 0 or g > best_g):
                                    best_g, best_e, best_s, bnx, bny = g, e, s, nx, ny
                    e = nxt[e]
        if best_e >= 0:
            f = -k_pen * best_g
            a = edges[best_e, 0]
            b = edges[best_e, 1]
            fx[i] += f * bnx
            fy[i] += f * bny
            fx[a] -= (1.0 - best_s) * f * bnx
            fy[a] -= (1.0 - best_s) * f * bny
            fx[b] -= best_s * f * bnx
            fy[b] -= best_s * f * bny
            if -best_g > out[0]:
                out[0] = -best_g


def connected_parts(quads: np.ndarray, alive: np.ndarray, n_nodes: int) -> np.ndarray:
    """Label of the connected part (fragment) of every living element (shared nodes connect)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    ids = np.nonzero(alive)[0]
    n_el = quads.shape[0]
    rows = np.repeat(ids, 4)
    cols = quads[ids].reshape(-1)
    g = coo_matrix((np.ones(rows.size), (rows, n_el + cols)), shape=(n_el + n_nodes, n_el + n_nodes))
    _, lab = connected_components(g, directed=False)
    return lab[:n_el]


class FragmentContact:
    """The exposed boundary and its cell list; ``rebuild`` after deletions, ``apply`` each step."""

    def __init__(self, quads: np.ndarray, n_nodes: int, cell: float, k_pen: float):
        self.quads = quads
        self.n_nodes = n_nodes
        self.cell = cell
        self.k_pen = k_pen
        self.out = np.zeros(1)
        self.n_alive = -1
        self.work = 0.0  # work done on the nodes by the fragment impulses [J/m] (set by the driver)

    def rebuild(self, px, py, alive):
        """Exposed edges/nodes of the living mesh, their parts, and the edge cell list."""
        self._pending = False
        self.n_alive = int(alive.sum())
        self.edges = boundary_edges(self.quads, alive)
        lab = connected_parts(self.quads, alive, self.n_nodes)
        self.part = lab[self.edges[:, 2]].astype(np.int64)
        nodes, first = np.unique(self.edges[:, 0], return_index=True)
        self.nodes = nodes.astype(np.int64)
        self.node_part = self.part[first]
        self.x0 = float(px.min()) - self.cell
        self.y0 = float(py.min()) - self.cell
        self.ncx = int((px.max() - self.x0) / self.cell) + 2
        self.ncy = int((py.max() - self.y0) / self.cell) + 2
        self.head = np.empty(self.ncx * self.ncy, np.int64)
        self.nxt = np.empty(max(self.edges.shape[0], 1), np.int64)
        _build_cells(px, py, self.edges, self.x0, self.y0, self.cell, self.ncx, self.ncy, self.head, self.nxt)
        self.n_parts = int(np.unique(self.part).size) if self.part.size else 0

    def active(self, alive) -> bool:
        """True when deleted elements have split the mesh into two or more parts (rebuilt on change)."""
        n = int(alive.sum())
        if n == alive.shape[0]:
            return False
        if n != self.n_alive:
            self._pending = True
        return True

    def refresh(self, px, py):
        """Re-bin the exposed edges after the nodes moved (same boundary)."""
        if getattr(self, "_pending", False) or not hasattr(self, "edges"):
            return
        self.x0 = float(px.min()) - self.cell
        self.y0 = float(py.min()) - self.cell
        self.ncx = int((px.max() - self.x0) / self.cell) + 2
        self.ncy = int((py.max() - self.y0) / self.cell) + 2
        if self.head.size < self.ncx * self.ncy:
            self.head = np.empty(self.ncx * self.ncy, np.int64)
        _build_cells(px, py, self.edges, self.x0, self.y0, self.cell, self.ncx, self.ncy, self.head, self.nxt)

    def apply(self, px, py, fx, fy):
        if self.n_parts < 2:
            return
        fragment_contact(px, py, self.edges, self.part, self.nodes, self.node_part, self.x0, self.y0, self.cell,
                         self.ncx, self.ncy, self.head, self.nxt, self.k_pen, fx, fy, self.out)
