"""Contact: the rigid tool against nodes/particles, and fragments against the workpiece.

Tool contact (contract in the engine's chunk loop): node-to-rigid-surface penalty with the
exact signed distance of :func:`solver.tool.tool_sdf`, Coulomb friction (the explicit step's stick/slip
return map, :func:`friction_scale`).

Fragment contact: pieces separated by deleted elements or failed interfaces must not pass through
each other, nor through the body they came from. Node-to-exposed-edge penalty, as self-contact
(the classic node-to-segment scheme, e.g. Belytschko, Liu & Moran, "Nonlinear Finite Elements for
Continua and Structures", 2nd ed., sec. 10.4; penalty form): every exposed boundary node is tested
against every exposed edge except those of its own elements, found through a cell list of the
edges that the engine re-bins at every step (:func:`fragment_contact_step`, O(N) in the exposed
nodes). Self-contact, not contact between connected parts: the fibre and matrix strips stay joined
through the homogeneous material around them, so after an interface fails the whole workpiece is
still one part, yet a matrix element must not slide into the fibre it came off. The exposed
boundary is the living mesh's free boundary minus the interface edges whose cohesive element is
still intact (it holds the two faces together itself); it is rebuilt (:class:`FragmentContact`)
when elements have been deleted or interfaces have debonded.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .binning import count_boxes, fill_boxes
from .tool import tool_bounds, tool_face, tool_sdf


@numba.njit(inline="always", cache=True)
def friction_scale(mu_fn, vt, eps, m, dt):
    """The friction force per unit predicted slip on one node, f_T = -scale w_t: Coulomb's law as the
    stick/slip return map of an explicit step (the trial force that stops the slip, Coulomb's limit where
    the trial exceeds it: Wriggers, Computational Contact Mechanics, 2006, sec. 5.2; the predictor-corrector
    contact of Taylor & Flanagan's PRONTO, 1987, and Heinstein et al. 1993), scale = min(m / dt,
    mu |f_N| / |w_t|).

    w_t is the predicted slip: the tangential velocity relative to the tool that the node would have after
    the step without friction, w_t = v_t + (dt / m) f_t, with f_t the tangential part of the other forces
    on it (:func:`tool_contact`). The trial force -(m / dt) w_t is what makes the slip zero after the step:
    where it is within Coulomb's cone the node sticks, else it slides against mu |f_N|. Without the other
    forces in w_t the trial only stops the slip the node already has: a node pushed along the face then
    creeps at (dt / m) |f_t| per step, a drift proportional to the step that let the quick 0-degree chip
    slide up the rake face at a speed of the tool's order and made the cutting force depend on the step.
    With dt = 0 (no step known) the law is Coulomb's regularised over eps (Oden & Martins 1985),
    mu |f_N| / sqrt(|w_t|^2 + eps^2)."""
    scale = mu_fn / math.sqrt(vt * vt + eps * eps)
    if dt > 0.0 and scale * dt > m:
        scale = m / dt
    return scale


@numba.njit(cache=True)
def tool_contact(px, py, vx, vy, mass, node_active, tool, k, mu, fx, fy, out, by_mass=0, dt=0.0, fox=None, foy=None,
                 other_per_mass=0, fix_x=None, fix_y=None):
    """Penalty contact + Coulomb friction between the rigid tool and nodes (or particles).

    For a node of mass m_i with signed distance sd < 0 (penetration g = -sd) and outward tool normal n:
        f_N = k_i * g * n,   k_i = k m_i (by_mass) or k       (penalty, N per m width)
        v_t = (v - v_tool) - ((v - v_tool) . n) n            (slip velocity)
        w_t = v_t + (dt / m_i) f_o,t                        (predicted slip, f_o the other forces)
        f_T = -min(m_i / dt, mu |f_N| / |w_t|) w_t           (Coulomb's stick/slip return map)
    (:func:`friction_scale`), with fox, foy the other forces on each node at this step (the internal
    forces; with ``other_per_mass`` per unit mass, accelerations; without them w_t = v_t), less their
    components on prescribed dofs (fix_x, fix_y nonzero: the supports take those). With dt = 0 the
    friction is Coulomb's regularised over eps = 1e-3 |v_tool| + 1e-9 m/s (Oden & Martins 1985),
    f_T = -mu |f_N| w_t / sqrt(|w_t|^2 + eps^2).
    Forces are added to fx, fy. ``out[0:2]`` accumulate the reaction on the tool (minus the sum
    of the forces added), ``out[2]`` the deepest penetration [m], ``out[3]`` the frictional power
    -f_T . v_t [W/m] at the slip the node has (a sticking node's is about zero); when ``out`` has 10
    entries, ``out[4 + 2 f], out[5 + 2 f]`` accumulate the reaction from contacts on face f of the tool
    (0 rake face, 1 cutting edge, 2 clearance face; :func:`solver.tool.tool_face`): which part of the tool
    the forces come from.

    With ``by_mass`` the penalty scales with each node's own mass, k_i = k m_i with k = alpha / dt^2
    [1/s^2] (:func:`contact_stiffness` of a unit mass; the IWF codes' alpha m g / dt^2, docs/model.md "Numerics",
    and LS-DYNA's soft-constraint contact, SOFT=1, k = SOFSCL m / dt^2): every node's contact
    oscillator has the same period 2 pi / sqrt(k), so the contact limits no node's step more than
    the lightest one's, while a heavy node is held as firmly as a light one (the same acceleration per
    unit penetration). The engine's nodes use it (a single stiffness set by the lightest node let
    heavier nodes sink deeper: 11-19 % of the element size at 90 degrees), and so do the hybrid's
    particles, whose step :func:`solver.sph.loop.stable_dt` holds to 1 / sqrt(k) (a version tried
    it without that limit: a damaged particle's signal-speed step put omega dt at 3, the D = 0.99
    stability case's particles took 36 times more work from the tool and its energy error rose to
    1.8 %). Without it every node or particle has the same k [N/m per m width].
    """
    vtx = tool[2]
    vty = tool[3]
    eps = 1e-3 * math.sqrt(vtx * vtx + vty * vty) + 1e-9
    by_face = out.shape[0] >= 10
    y_lo, q_lo = tool_bounds(tool)
    for i in range(px.shape[0]):
        if node_active[i] == 0:
            continue
        if py[i] < y_lo or tool[11] * (px[i] - tool[0]) < q_lo:  # below the tool or ahead of it: no contact
            continue
        sd, nx, ny = tool_sdf(px[i], py[i], tool)
        if sd >= 0.0:
            continue
        g = -sd
        fn = k * mass[i] * g if by_mass != 0 else k * g
        fxi = fn * nx
        fyi = fn * ny
        rvx = vx[i] - vtx
        rvy = vy[i] - vty
        vn = rvx * nx + rvy * ny
        tx = rvx - vn * nx
        ty = rvy - vn * ny
        if mu > 0.0:
            wx = tx  # the predicted slip (friction_scale)
            wy = ty
            if fox is not None and dt > 0.0 and mass[i] > 0.0:
                c = dt if other_per_mass != 0 else dt / mass[i]
                ox = fox[i]
                oy = foy[i]
                if fix_x is not None:
                    if fix_x[i] != 0:
                        ox = 0.0
                    if fix_y[i] != 0:
                        oy = 0.0
                fon = ox * nx + oy * ny
                wx += c * (ox - fon * nx)
                wy += c * (oy - fon * ny)
            wt = math.sqrt(wx * wx + wy * wy)
            if wt > 0.0:
                scale = friction_scale(mu * fn, wt, eps, mass[i], dt)
                fxi -= scale * wx
                fyi -= scale * wy
                out[3] += scale * (wx * tx + wy * ty)  # -f_T . v_t, the friction's power at the node's slip
        fx[i] += fxi
        fy[i] += fyi
        out[0] -= fxi
        out[1] -= fyi
        if by_face:
            f = tool_face(nx, ny, tool)
            out[4 + 2 * f] -= fxi
            out[5 + 2 * f] -= fyi
        if g > out[2]:
            out[2] = g


#: the rigid tool's penalty k_i = TOOL_ALPHA m_i / dt^2: its contact oscillator turns by omega dt = 1 a step
#: (central differences are stable to 2, and the engine's step keeps the contact's own limit). Softer, the
#: penalty is a spring in series with the workpiece that widens the contact: against Hertz's line contact
#: (``fibrecut verify tool-hertz``) alpha = 0.1 made the contact 14 % too wide with 7 elements across its
#: half-width and 25 % with 3.4; alpha = 1 makes it 3.3 % and 5.6 %
TOOL_ALPHA = 1.0
#: the penalty between two deformable bodies (fragments, particles and element edges): k = PAIR_ALPHA m / dt^2
#: on the lightest node; a pair of light bodies turns sqrt(2) faster than one body on the rigid tool
#: (the IWF mfree codes' alpha m / dt^2 with alpha ~ 0.1, docs/model.md "Numerics")
PAIR_ALPHA = 0.1


def contact_stiffness(node_mass_min: float, dt: float, factor: float = 1.0, alpha: float = PAIR_ALPHA) -> float:
    """Penalty stiffness consistent with the explicit step: k = alpha m_min / dt^2 x factor.

    A node of mass m on a spring k is stable for dt < 2 sqrt(m/k): with alpha = 0.1 the contact's own
    limit is 2 sqrt(10) dt ~ 6.3 dt, with the tool's alpha = 1 it is 2 dt; neither limits the step.
    """
    return alpha * node_mass_min / (dt * dt) * factor


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


@numba.njit(cache=True, inline="always")
def node_segment_push(fxp, fyp, i, fxe, fye, a, b, s, f, nx, ny):
    """The node-to-segment penalty pair (Belytschko, Liu & Moran 2014, sec. 10.4): f n on the point i
    (into fxp, fyp) and -(1 - s) f n, -s f n on the segment's nodes a, b (into fxe, fye)."""
    fxp[i] += f * nx
    fyp[i] += f * ny
    fxe[a] -= (1.0 - s) * f * nx
    fye[a] -= (1.0 - s) * f * ny
    fxe[b] -= s * f * nx
    fye[b] -= s * f * ny


@numba.njit(cache=True)
def _build_cells(px, py, edges, x0, y0, cell, ncx, ncy, start, items):
    """Cell list of edges by their midpoint (CSR, :mod:`solver.binning`: the edges of cell c are
    items[start[c]:start[c + 1]], in decreasing edge order; start has ncx ncy + 1 entries, items one per
    edge); used by the hybrid's particle-edge coupling (solver.hybrid.coupler), whose cell is the longest
    exposed edge."""
    box = np.empty((edges.shape[0], 4), np.int64)
    for e in range(edges.shape[0]):
        mx = 0.5 * (px[edges[e, 0]] + px[edges[e, 1]])
        my = 0.5 * (py[edges[e, 0]] + py[edges[e, 1]])
        cx = min(max(int((mx - x0) / cell), 0), ncx - 1)
        cy = min(max(int((my - y0) / cell), 0), ncy - 1)
        box[e, 0] = cx
        box[e, 1] = cx
        box[e, 2] = cy
        box[e, 3] = cy
    count_boxes(box, ncx, start)
    fill_boxes(box, ncx, start, items, True)


@numba.njit(cache=True, inline="always")
def _edge_cells(px, py, a, b, pad, x0, y0, cell, ncx, ncy):
    """The cell range (i0, i1, j0, j1) the bounding box of edge (a, b), grown by pad, overlaps, clamped to the grid."""
    i0 = min(max(int((min(px[a], px[b]) - pad - x0) / cell), 0), ncx - 1)
    i1 = min(max(int((max(px[a], px[b]) + pad - x0) / cell), 0), ncx - 1)
    j0 = min(max(int((min(py[a], py[b]) - pad - y0) / cell), 0), ncy - 1)
    j1 = min(max(int((max(py[a], py[b]) + pad - y0) / cell), 0), ncy - 1)
    return i0, i1, j0, j1


@numba.njit(cache=True)
def fragment_contact_step(px, py, vx, vy, dtprev, edges, enodes, nodes, alive, node_active, grid, cstart, cent, depth,
                          ffx, ffy, out):
    """Node-to-exposed-edge penalty (self-contact of the fragmented workpiece) for one step.

    For every exposed node i the exposed edges (a, b) binned in its cell are tested, except the
    edges of the elements node i belongs to (``enodes[e]``: the four nodes of edge e's element).
    The lists are rebuilt between chunks; until then an edge of an element deleted since
    (``alive[edges[e, 2]] == 0``) and a node no living element holds (``node_active``) are skipped
    (in the hybrid such a node has given its mass to a particle). The test: s = ((x_i - x_a) . (x_b - x_a)) / |x_b - x_a|^2 in [0, 1], gap
    g = (x_i - x_a) . n (n the outward normal of the edge's element). A node is in contact when
    g < 0 and the penetration can have come from the last step's motion:

        -g <= depth_i + dt_prev |v_i - v_edge(s)| + 1e-3 |x_b - x_a|

    with depth_i its penetration at the step before (0 when it was outside). A node found deep
    inside a fragment it never crossed into (the geometry of a freshly exposed surface) is thus
    left alone instead of being launched by the penalty. Of the admissible edges the one with
    the smallest penetration acts: f = -k g n on the node, -(1 - s) f and -s f on a and b
    (action = reaction; Belytschko, Liu & Moran 2014, sec. 10.4, penalty method).

    Binning (every step, O(edges)): grid = [x0, y0, cell, ncx, ncy, k, pad]; each edge goes into
    every cell its bounding box, grown by pad, overlaps (clamped to the grid, so far-away pieces
    share the border cells), as a CSR list (cstart, cent; :mod:`solver.binning`); a node tests the
    edges of its own cell. When cent is too small the step skips the contact and out[2] holds the size needed.
    Forces are written into ffx, ffy (zeroed here); depth[i] is updated; out[0] = max(out[0],
    deepest penetration [m]), out[1] = the number of nodes in contact this step.
    """
    x0 = grid[0]
    y0 = grid[1]
    cell = grid[2]
    ncx = int(grid[3])
    ncy = int(grid[4])
    k_pen = grid[5]
    pad = grid[6]
    for i in range(ffx.shape[0]):
        ffx[i] = 0.0
        ffy[i] = 0.0
    out[1] = 0.0
    box = np.empty((edges.shape[0], 4), np.int64)
    for e in range(edges.shape[0]):
        if alive[edges[e, 2]] == 0:
            box[e, 0] = -1
            continue
        box[e, 0], box[e, 1], box[e, 2], box[e, 3] = _edge_cells(px, py, edges[e, 0], edges[e, 1], pad, x0, y0,
                                                                 cell, ncx, ncy)
    total = count_boxes(box, ncx, cstart)
    if total > cent.shape[0]:
        out[2] = 2.0 * total
        return
    fill_boxes(box, ncx, cstart, cent)
    n_contact = 0
    for k in range(nodes.shape[0]):
        i = nodes[k]
        if node_active[i] == 0:
            depth[i] = 0.0
            continue
        xi = px[i]
        yi = py[i]
        c = min(max(int((yi - y0) / cell), 0), ncy - 1) * ncx + min(max(int((xi - x0) / cell), 0), ncx - 1)
        best_g = 0.0
        best_e = -1
        best_s = 0.0
        bnx = 0.0
        bny = 0.0
        for q in range(cstart[c], cstart[c + 1]):
            e = cent[q]
            a = edges[e, 0]
            b = edges[e, 1]
            if i == enodes[e, 0] or i == enodes[e, 1] or i == enodes[e, 2] or i == enodes[e, 3]:
                continue
            ax = px[a]
            ay = py[a]
            ex = px[b] - ax
            ey = py[b] - ay
            l2 = ex * ex + ey * ey
            if l2 <= 0.0:
                continue
            dx = xi - ax
            dy = yi - ay
            s = (dx * ex + dy * ey) / l2
            if s < 0.0 or s > 1.0:
                continue
            ln = math.sqrt(l2)
            nx = ey / ln
            ny = -ex / ln
            g = dx * nx + dy * ny
            if g < 0.0 and (best_e < 0 or g > best_g):
                rvx = vx[i] - (1.0 - s) * vx[a] - s * vx[b]
                rvy = vy[i] - (1.0 - s) * vy[a] - s * vy[b]
                reach = depth[i] + dtprev * math.sqrt(rvx * rvx + rvy * rvy) + 1e-3 * ln
                if -g <= reach:
                    best_g = g
                    best_e = e
                    best_s = s
                    bnx = nx
                    bny = ny
        if best_e >= 0:
            f = -k_pen * best_g
            a = edges[best_e, 0]
            b = edges[best_e, 1]
            node_segment_push(ffx, ffy, i, ffx, ffy, a, b, best_s, f, bnx, bny)
            depth[i] = -best_g
            n_contact += 1
            if -best_g > out[0]:
                out[0] = -best_g
        else:
            depth[i] = 0.0
    out[1] = n_contact


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


def _pair_keys(a: np.ndarray, b: np.ndarray, n_nodes: int) -> np.ndarray:
    """An order-free int64 key of each node pair (a_k, b_k)."""
    lo, hi = np.minimum(a, b).astype(np.int64), np.maximum(a, b).astype(np.int64)
    return lo * (n_nodes + 1) + hi


class ExposedBoundary:
    """The surfaces that can touch: the boundary edges of the living quads (:func:`boundary_edges`)
    without the faces of intact cohesive elements (an intact interface holds its two faces together;
    once it has debonded (cohesive state != 0) or lost a tied element, its faces are surfaces).
    ``edges(state)`` reads ``state.alive`` and, where the state has them, ``state.coh`` and
    ``state.cstate``."""

    def __init__(self, quads: np.ndarray, n_nodes: int):
        self.quads = quads
        self.n_nodes = n_nodes
        self._faces = None  # sorted keys of the cohesive elements' two faces, and the owning cohesive

    def state_key(self, state) -> tuple[int, int]:
        """(living elements, cohesive elements no longer intact): the exposed boundary changes with it."""
        cstate = getattr(state, "cstate", None)
        return int(state.alive.sum()), 0 if cstate is None else int(np.count_nonzero(cstate))

    def intact_faces(self, state, edges: np.ndarray) -> np.ndarray:
        """Mask of the edges that are a face of a still intact cohesive element."""
        coh = getattr(state, "coh", None)
        if coh is None or coh.shape[0] == 0 or edges.shape[0] == 0:
            return np.zeros(edges.shape[0], bool)
        if self._faces is None:
            keys = np.concatenate([_pair_keys(coh[:, 0], coh[:, 1], self.n_nodes),
                                   _pair_keys(coh[:, 2], coh[:, 3], self.n_nodes)])
            owner = np.concatenate([np.arange(coh.shape[0]), np.arange(coh.shape[0])])
            order = np.argsort(keys)
            self._faces = (keys[order], owner[order])
        keys, owner = self._faces
        ek = _pair_keys(edges[:, 0], edges[:, 1], self.n_nodes)
        pos = np.minimum(np.searchsorted(keys, ek), keys.size - 1)
        return (keys[pos] == ek) & (state.cstate[owner[pos]] == 0)

    def edges(self, state) -> np.ndarray:
        """(n, 3) [node0, node1, element] of the exposed edges (counter-clockwise per element)."""
        e = boundary_edges(self.quads, state.alive)
        return e[~self.intact_faces(state, e)]


#: cells of the fragment grid at most (a chip flying far makes the bounding box large; beyond
#: this the cell grows, which keeps the search correct and only costs more tests per node)
MAX_CELLS = 1 << 20


class FragmentContact:
    """The exposed boundary and its cell grid, written into the engine's state.

    ``rebuild(state)`` after elements were deleted or interfaces debonded: the boundary edges of the
    living mesh without the interface edges of intact cohesive elements, the four nodes of each
    edge's element (a node never contacts its own elements), the exposed nodes, and a grid over the
    current bounding box (cell = 2 x the median exposed edge) into ``state.fr_*``; it switches the
    engine's fragment contact on (``state.fr_on``). The engine re-bins and applies the contact at
    every step (:func:`fragment_contact_step`); ``grow(state)`` enlarges the bin list when the
    engine asked for more (edges stretched).
    """

    def __init__(self, quads: np.ndarray, n_nodes: int, k_pen: float):
        self.quads = quads
        self.n_nodes = n_nodes
        self.k_pen = float(k_pen)
        self.key = (-1, -1)
        self.rebuilds = 0
        self.seconds = 0.0  # time spent rebuilding [s]
        self.exposed = ExposedBoundary(quads, n_nodes)

    def needs_rebuild(self, state) -> bool:
        """True once an element was deleted or a cohesive element debonded since the last rebuild."""
        key = self.exposed.state_key(state)
        if key == self.key:
            return False
        return key[0] != state.alive.shape[0] or key[1] > 0

    def grow(self, state) -> bool:
        need = int(state.fr_out[2])
        if need > state.fr_cent.shape[0]:
            state.fr_cent = np.empty(need, np.int64)
            state.fr_out[2] = 0.0
            return True
        return False

    def rebuild(self, state):
        if state.fr_depth.shape[0] != self.n_nodes:  # the per-node arrays, on the first deletion
            from .fem.state import no_fragments

            no_fragments(state, self.n_nodes)
        px, py = state.x, state.y
        self.key = self.exposed.state_key(state)
        self.rebuilds += 1
        edges = self.exposed.edges(state)
        nodes = np.unique(edges[:, :2])
        if edges.shape[0]:
            ex = px[edges[:, 1]] - px[edges[:, 0]]
            ey = py[edges[:, 1]] - py[edges[:, 0]]
            typical = float(np.median(np.sqrt(ex * ex + ey * ey)))
        else:
            typical = 1e-6
        # cells of about two typical edges; longer edges are binned into every cell they cross
        cell = 2.0 * max(typical, 1e-12)
        # over the exposed nodes (a node no living element holds can drift away with the velocity it
        # had: in the hybrid a massless node at 14 km/s made a grid of 1e6 cells, zeroed at every step,
        # and the run three times slower), and at most the workpiece's size beyond its initial box:
        # pieces farther out share the border cells
        ext = nodes if nodes.size else np.arange(px.size)
        X0, Y0 = state.X0, state.Y0
        size = max(float(X0.max() - X0.min()), float(Y0.max() - Y0.min()))
        lo_x, hi_x = max(float(px[ext].min()), float(X0.min()) - size), min(float(px[ext].max()), float(X0.max()) + size)
        lo_y, hi_y = max(float(py[ext].min()), float(Y0.min()) - size), min(float(py[ext].max()), float(Y0.max()) + size)
        x0, y0 = lo_x - cell, lo_y - cell
        w, h = max(hi_x - x0, 0.0) + cell, max(hi_y - y0, 0.0) + cell
        while (w / cell + 1) * (h / cell + 1) > MAX_CELLS:
            cell *= 1.5
        ncx, ncy = int(w / cell) + 2, int(h / cell) + 2
        state.fr_edges = np.ascontiguousarray(edges)
        state.fr_enodes = np.ascontiguousarray(self.quads[edges[:, 2]], dtype=np.int64).reshape(-1, 4)
        state.fr_nodes = nodes.astype(np.int64)
        state.fr_grid = np.array([x0, y0, cell, ncx, ncy, self.k_pen, 0.25 * cell])
        state.fr_cstart = np.zeros(ncx * ncy + 1, np.int64)
        state.fr_cent = np.empty(max(4 * edges.shape[0], 16), np.int64)
        state.fr_on = 1 if edges.shape[0] else 0
