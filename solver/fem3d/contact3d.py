"""Contact in the 3D hexahedral engine: a rigid body (the cutting tool, or a sphere) against the nodes, the
fragments of the mesh against each other, and the symmetry planes of a strip.

The tool in 3D is the 2D tool's profile (:mod:`solver.tool`: rake face, edge arc, clearance face) extruded
along z across the strip: a node's signed distance and outward normal are the 2D tool's at its (x, y)
(:func:`solver.tool.tool_sdf`, the same compiled function the 2D engine uses), with a zero z-component
of the normal. The sphere (:func:`sphere_sdf`, for Hertz's point contact) is the other rigid body.

Penalty and friction (:func:`rigid_contact3d`), as the 2D engine's :func:`solver.contact.tool_contact`
in three components: a node of mass m_i at penetration g = -sd > 0 with outward normal n gets

    f_N = k m_i g n,   k = TOOL_ALPHA / dt^2                   (solver.contact.TOOL_ALPHA)
    v_t = (v - v_body) - ((v - v_body) . n) n                (slip velocity)
    w_t = v_t + (dt / m_i) f_o,t                             (predicted slip, f_o the other forces)
    f_T = -min(m_i / dt, mu |f_N| / |w_t|) w_t               (Coulomb's stick/slip return map)

(:func:`solver.contact.friction_scale`: the trial force stops the slip the node would have after the step,
within Coulomb's cone the node sticks, else it slides; with dt = 0 Coulomb's law regularised over
eps = 1e-3 |v_body| + 1e-9 m/s, Oden & Martins 1985). The forces are those of the 2D tool per node; in
3D they are forces [N], so the tool's force per metre of strip width is the sum divided by the strip's
width (the 2D engine reports N/m).

The rigid body's array ``state.tool`` (float64, :data:`N_BODY`), kind ``state.tool_par[0]``:
    kind 0, the extruded tool: :func:`solver.tool.tool_array`'s layout ([0], [1] arc centre x, y,
    [2], [3] velocity x, y, [4] edge radius, ...); it moves in the x-y plane.
    kind 1, a sphere: [0], [1] centre x, y, [2], [3] velocity x, y, [4] radius, [5] centre z,
    [6] velocity z.
``state.tool_par`` = [kind, k, mu]; no body = an empty ``state.tool`` (the loop's contact phase is one
branch then).

Bookkeeping (by the loop, :func:`solver.fem3d.loop._chunk`): ``fcon`` (3, n) the contact forces of the
step (added to the nodal forces), ``fconp`` the previous step's; ``tool_now`` (:data:`N_OUT`) this step's
[0:3] force on the body [N], [3] deepest penetration [m], [4] friction power [W], [5 + 3 f + c] the force
on the tool's face f (0 rake, 1 edge, 2 clearance; :func:`solver.tool.tool_face`) along axis c;
``tool_out`` the same summed over the steps ([3]: the largest; [4]: the friction's dissipation [J]);
``tool_en`` = [work of the body on the workpiece (minus force on the body . body velocity), work of the
contact forces on the nodes, friction dissipation, last step's force on the body x, y, z and friction
power] (trapezoidal in time, as the 2D engine books them). The penalty springs' energy is the body's
work minus the work on the nodes minus the friction.

Symmetry planes (:func:`symmetry_plane`, :func:`strip_sides`): the nodes on a plane normal to an axis are
held along that axis (``state.fix``, ``state.vp`` = 0): a strip with both sides held deforms in plane
strain, a quarter model with two planes through the axis of a sphere is the full block's quarter.

Fragment contact (:func:`fragment_contact3d`, :class:`FragmentContact3D`): pieces that are no longer
joined must not pass through each other, as the 2D engine's :func:`solver.contact.fragment_contact_step`
(node-to-segment there, node-to-face here; Belytschko, Liu & Moran 2014, sec. 10.4, penalty form): every
node of the exposed boundary (the living hexahedra's free faces without the faces of intact cohesive elements)
is tested against the exposed faces binned in its cell of a grid, except the faces of its own elements;
each quadrilateral face is split into two triangles (0, 1, 2) and (0, 2, 3) with their outward normal.
A node behind a triangle (gap g < 0, its projection inside) whose penetration can have come from the last
step's motion (-g <= its depth at the last step + dt_prev |v_i - v_face| + 1e-3 sqrt(2 x the triangle's
area), the 2D rule) gets f = -k g n, and the triangle's nodes -w_j f n (w_j the projection's barycentric
weights: action = reaction); of the admissible triangles the one with the smallest penetration acts.
k = PAIR_ALPHA m_min / dt^2 (:func:`solver.contact.contact_stiffness`). The exposed boundary is rebuilt
between chunks (:meth:`FragmentContact3D.rebuild`), once elements were deleted or cohesive elements have
debonded: the faces of the living elements.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from ..binning import count_hulls3d, fill_hulls3d, point_cell3d
from ..contact import TOOL_ALPHA, friction_scale
from ..tool import tool_bounds, tool_face, tool_sdf

#: length of the rigid body's array (:func:`solver.tool.tool_array`'s; the sphere uses its first 7)
N_BODY = 12
#: kinds of rigid body
KIND_TOOL, KIND_SPHERE = 0, 1
#: length of the per-step output (force, deepest penetration, friction power, force by face)
N_OUT = 14


@numba.njit(cache=True, inline="always")
def sphere_sdf(px, py, pz, body):
    """Signed distance |p - c| - R from (px, py, pz) to a sphere (centre body[0], body[1], body[5], radius
    body[4]) and its outward unit normal (p - c) / |p - c| (straight up at the centre)."""
    dx = px - body[0]
    dy = py - body[1]
    dz = pz - body[5]
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if d > 0.0:
        return d - body[4], dx / d, dy / d, dz / d
    return -body[4], 0.0, 1.0, 0.0


@numba.njit(cache=True)
def rigid_contact3d(x, v, mass, body, kind, k, mu, fcon, out, dt=0.0, fo=None, fix=None, other_per_mass=0):
    """Penalty contact and Coulomb friction of a rigid body against every node (module docstring), the
    friction's stick/slip trial from the other forces fo (3, n) on the nodes at this step (accelerations with
    ``other_per_mass``), less their components on prescribed dofs (``fix`` nonzero; no fo: the slip they
    have): forces into fcon (3, n) (overwritten), this step's totals into out (:data:`N_OUT`,
    overwritten). kind 0: the 2D tool extruded along z (:func:`solver.tool.tool_sdf` of (x, y)), 1: a
    sphere (:func:`sphere_sdf`). Cost linear in the number of nodes."""
    for j in range(out.shape[0]):
        out[j] = 0.0
    vbx = body[2]
    vby = body[3]
    vbz = body[6] if kind == KIND_SPHERE else 0.0
    eps = 1e-3 * math.sqrt(vbx * vbx + vby * vby + vbz * vbz) + 1e-9
    y_lo, q_lo = (-math.inf, -math.inf) if kind == KIND_SPHERE else tool_bounds(body)
    for i in range(x.shape[1]):
        fcon[0, i] = 0.0
        fcon[1, i] = 0.0
        fcon[2, i] = 0.0
        if kind == KIND_SPHERE:
            sd, nx, ny, nz = sphere_sdf(x[0, i], x[1, i], x[2, i], body)
        else:
            if x[1, i] < y_lo or body[11] * (x[0, i] - body[0]) < q_lo:  # below or ahead of the tool
                continue
            sd, nx, ny = tool_sdf(x[0, i], x[1, i], body)
            nz = 0.0
        if sd >= 0.0 or mass[i] <= 0.0:
            continue
        g = -sd
        fn = k * mass[i] * g
        fx = fn * nx
        fy = fn * ny
        fz = fn * nz
        rvx = v[0, i] - vbx
        rvy = v[1, i] - vby
        rvz = v[2, i] - vbz
        vn = rvx * nx + rvy * ny + rvz * nz
        tx = rvx - vn * nx
        ty = rvy - vn * ny
        tz = rvz - vn * nz
        if mu > 0.0:
            wx = tx  # the predicted slip (solver.contact.friction_scale)
            wy = ty
            wz = tz
            if fo is not None and dt > 0.0:
                c = dt if other_per_mass != 0 else dt / mass[i]
                ox = fo[0, i]
                oy = fo[1, i]
                oz = fo[2, i]
                if fix is not None:
                    if fix[0, i] != 0:
                        ox = 0.0
                    if fix[1, i] != 0:
                        oy = 0.0
                    if fix[2, i] != 0:
                        oz = 0.0
                fon = ox * nx + oy * ny + oz * nz
                wx += c * (ox - fon * nx)
                wy += c * (oy - fon * ny)
                wz += c * (oz - fon * nz)
            wt = math.sqrt(wx * wx + wy * wy + wz * wz)
            if wt > 0.0:
                scale = friction_scale(mu * fn, wt, eps, mass[i], dt)
                fx -= scale * wx
                fy -= scale * wy
                fz -= scale * wz
                out[4] += scale * (wx * tx + wy * ty + wz * tz)  # -f_T . v_t at the node's slip
        fcon[0, i] = fx
        fcon[1, i] = fy
        fcon[2, i] = fz
        out[0] -= fx
        out[1] -= fy
        out[2] -= fz
        if kind == KIND_TOOL:
            f = tool_face(nx, ny, body)
            out[5 + 3 * f] -= fx
            out[6 + 3 * f] -= fy
            out[7 + 3 * f] -= fz
        if g > out[3]:
            out[3] = g


@numba.njit(cache=True)
def book_body(body, kind, now, ten, tout, dtprev, dt):
    """After the nodes' update: the body's work and the friction over [t^{n-1}, t^n] (trapezoidal, as
    the 2D engine's), the sums over steps, then the body moves by dt with its velocity."""
    vbz = body[6] if kind == KIND_SPHERE else 0.0
    ten[0] -= 0.5 * ((now[0] + ten[3]) * body[2] + (now[1] + ten[4]) * body[3] + (now[2] + ten[5]) * vbz) * dtprev
    ten[2] += 0.5 * (now[4] + ten[6]) * dtprev
    ten[3] = now[0]
    ten[4] = now[1]
    ten[5] = now[2]
    ten[6] = now[4]
    for j in range(now.shape[0]):
        if j == 3:
            if now[3] > tout[3]:
                tout[3] = now[3]
        elif j == 4:
            tout[4] = ten[2]
        else:
            tout[j] += now[j]
    body[0] += body[2] * dt
    body[1] += body[3] * dt
    if kind == KIND_SPHERE:
        body[5] += vbz * dt


# ------------------------------------------------------------------------------ fragments
#: the six faces of a hexahedron (:mod:`.hex8` numbering), each counter-clockwise seen from outside
HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])
#: fragment grid's parameters: [x0, y0, z0, cell, ncx, ncy, ncz, k, pad], then the outputs
#: [deepest penetration [m], nodes in contact (last step), entries needed, work on the nodes [J]]
FR_X0, FR_CELL, FR_N, FR_K, FR_PAD, FR_DEEP, FR_NC, FR_NEED, FR_WORK = 0, 3, 4, 7, 8, 9, 10, 11, 12
N_FR = 13


@numba.njit(cache=True, inline="always")
def triangle_normal(x, a, b, c):
    """(nx, ny, nz, l): the unit normal (x_b - x_a) x (x_c - x_a) / l of the triangle (a, b, c) (counter-clockwise
    seen from the side it points to) and l, twice its area (0 and a zero normal for a degenerate one)."""
    e1x, e1y, e1z = x[0, b] - x[0, a], x[1, b] - x[1, a], x[2, b] - x[2, a]
    e2x, e2y, e2z = x[0, c] - x[0, a], x[1, c] - x[1, a], x[2, c] - x[2, a]
    nx = e1y * e2z - e1z * e2y
    ny = e1z * e2x - e1x * e2z
    nz = e1x * e2y - e1y * e2x
    ln = math.sqrt(nx * nx + ny * ny + nz * nz)
    if ln <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    return nx / ln, ny / ln, nz / ln, ln


@numba.njit(cache=True)
def _bin_faces(x, faces, par, cstart, cent):
    """CSR of the faces per cell (each face in every cell its bounding box, grown by pad, overlaps; faces
    outside the grid clamped into its border cells, :func:`solver.binning.count_hulls3d`); returns False
    (and the size needed in par[FR_NEED]) when cent is too short."""
    total = count_hulls3d(x, faces, 4, par, par[FR_PAD], False, cstart)
    if total > cent.shape[0]:
        par[FR_NEED] = 2.0 * total
        return False
    fill_hulls3d(x, faces, 4, par, par[FR_PAD], False, cstart, cent)
    return True


@numba.njit(cache=True)
def fragment_contact3d(x, v, dtprev, faces, nodes, par, cstart, cent, depth, ffr):
    """Node-to-face penalty between the exposed faces (module docstring) for one step: forces into ffr (3, n)
    (overwritten), depth per node updated, par[FR_DEEP] = max(., deepest penetration), par[FR_NC] = nodes in
    contact. faces (nf, 12): the face's 4 nodes, then its element's 8. Binning every step, cost linear in
    the exposed faces and nodes."""
    for i in range(ffr.shape[1]):
        ffr[0, i] = 0.0
        ffr[1, i] = 0.0
        ffr[2, i] = 0.0
    par[FR_NC] = 0.0
    if not _bin_faces(x, faces, par, cstart, cent):
        return
    cell = par[FR_CELL]
    ncx, ncy, ncz = int(par[FR_N]), int(par[FR_N + 1]), int(par[FR_N + 2])
    k_pen = par[FR_K]
    ncontact = 0
    for q in range(nodes.shape[0]):
        i = nodes[q]
        px, py, pz = x[0, i], x[1, i], x[2, i]
        c = point_cell3d(px, py, pz, par[FR_X0], par[FR_X0 + 1], par[FR_X0 + 2], cell, ncx, ncy, ncz)
        best_g = 0.0
        best = -1
        bnx = bny = bnz = 0.0
        bwa = bwb = bwc = 0.0
        ba = bb = bc = 0
        for m in range(cstart[c], cstart[c + 1]):
            e = cent[m]
            own = False
            for j in range(4, 12):
                if faces[e, j] == i:
                    own = True
            if own:
                continue
            for t in range(2):
                a = faces[e, 0]
                b = faces[e, 1 + t]
                cc = faces[e, 2 + t]
                nx, ny, nz, a2 = triangle_normal(x, a, b, cc)
                if a2 <= 0.0:
                    continue
                e1x, e1y, e1z = x[0, b] - x[0, a], x[1, b] - x[1, a], x[2, b] - x[2, a]
                e2x, e2y, e2z = x[0, cc] - x[0, a], x[1, cc] - x[1, a], x[2, cc] - x[2, a]
                dx, dy, dz = px - x[0, a], py - x[1, a], pz - x[2, a]
                g = dx * nx + dy * ny + dz * nz
                if g >= 0.0 or (best >= 0 and g <= best_g):
                    continue
                qx, qy, qz = dx - g * nx, dy - g * ny, dz - g * nz
                d00 = e1x * e1x + e1y * e1y + e1z * e1z
                d01 = e1x * e2x + e1y * e2y + e1z * e2z
                d11 = e2x * e2x + e2y * e2y + e2z * e2z
                d20 = qx * e1x + qy * e1y + qz * e1z
                d21 = qx * e2x + qy * e2y + qz * e2z
                den = d00 * d11 - d01 * d01
                wb = (d11 * d20 - d01 * d21) / den
                wc = (d00 * d21 - d01 * d20) / den
                wa = 1.0 - wb - wc
                if wa < 0.0 or wb < 0.0 or wc < 0.0:
                    continue
                rvx = v[0, i] - wa * v[0, a] - wb * v[0, b] - wc * v[0, cc]
                rvy = v[1, i] - wa * v[1, a] - wb * v[1, b] - wc * v[1, cc]
                rvz = v[2, i] - wa * v[2, a] - wb * v[2, b] - wc * v[2, cc]
                reach = depth[i] + dtprev * math.sqrt(rvx * rvx + rvy * rvy + rvz * rvz) + 1e-3 * math.sqrt(a2)
                if -g <= reach:
                    best = e
                    best_g = g
                    bnx, bny, bnz = nx, ny, nz
                    bwa, bwb, bwc = wa, wb, wc
                    ba, bb, bc = a, b, cc
        if best >= 0:
            f = -k_pen * best_g
            for d in range(3):
                fd = f * (bnx if d == 0 else (bny if d == 1 else bnz))
                ffr[d, i] += fd
                ffr[d, ba] -= bwa * fd
                ffr[d, bb] -= bwb * fd
                ffr[d, bc] -= bwc * fd
            depth[i] = -best_g
            ncontact += 1
            if -best_g > par[FR_DEEP]:
                par[FR_DEEP] = -best_g
        else:
            depth[i] = 0.0
    par[FR_NC] = ncontact


def boundary_faces(hexes: np.ndarray) -> np.ndarray:
    """(nf, 5) [4 nodes counter-clockwise seen from outside, element] of the faces no other hexahedron shares."""
    f = hexes[:, HEX_FACES].reshape(-1, 4)
    el = np.repeat(np.arange(hexes.shape[0]), 6)
    key = np.sort(f, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    single = counts[inv.reshape(-1)] == 1
    return np.hstack([f[single], el[single, None]]).astype(np.int64)


def living_faces(state, sides: tuple[float, ...] = ()) -> np.ndarray:
    """(nf, 5) [4 nodes counter-clockwise seen from outside, element] of the living hexahedra's free faces,
    without those whose four nodes lie (in the reference configuration) on one of the planes z = ``sides``
    (a strip's symmetry sides: their nodes stay on them, nothing comes through)."""
    alive = np.asarray(state.alive) != 0
    live = np.flatnonzero(alive)
    f = boundary_faces(state.hexes[live])
    f[:, 4] = live[f[:, 4]]
    if sides and f.shape[0]:
        z = state.X0[2, f[:, :4]]
        tol = 1e-9 * float(np.ptp(state.X0[2]))
        on_side = np.zeros(f.shape[0], bool)
        for zs in sides:
            on_side |= np.all(np.abs(z - zs) <= tol, axis=1)
        f = f[~on_side]
    return f


def no_fragments(state) -> None:
    """The fragment-contact fields of a state without it (empty: the loop skips it)."""
    n = state.x.shape[1]
    state.fr_faces = np.zeros((0, 12), np.int64)
    state.fr_nodes = np.zeros(0, np.int64)
    state.fr_par = np.zeros(N_FR)
    state.fr_cstart = np.zeros(1, np.int64)
    state.fr_cent = np.zeros(0, np.int64)
    state.fr_depth = np.zeros(n)
    state.ffr = np.zeros((3, n))
    state.ffrp = np.zeros((3, n))


class FragmentContact3D:
    """The exposed faces and their grid, written into the state (``state.fr_*``); ``rebuild(state)`` between
    chunks once elements were deleted or cohesive elements debonded (``needs_rebuild``), ``grow(state)`` when
    the loop asked for a longer bin list. k_pen: the penalty [N/m] (default PAIR_ALPHA m_min / dt^2 at the
    stable step). ``sides``: the z of planes whose faces are left out (a strip's symmetry sides: their nodes
    stay on them, no piece can come through)."""

    def __init__(self, state, k_pen: float | None = None, sides: tuple[float, ...] = ()):
        from ..contact import contact_stiffness

        self.faces = boundary_faces(state.hexes)
        if k_pen is None:
            k_pen = contact_stiffness(float(state.mass[state.mass > 0].min()),
                                      state.cfl * min(state.dt_crit, state.dt_cohesive))
        self.k_pen = float(k_pen)
        self.sides = tuple(float(z) for z in sides)
        self.key = (-1, -1)
        self.rebuilds = 0
        self.seconds = 0.0  # time spent rebuilding [s]

    def state_key(self, state) -> tuple[int, int]:
        """(living elements, cohesive elements no longer intact): the exposed boundary changes with it."""
        return int(np.count_nonzero(state.alive)), int(np.count_nonzero(state.cstate))

    def exposed(self, state) -> np.ndarray:
        """The boundary faces of the living elements without those of intact cohesive elements (an intact
        interface holds its faces) and those on the ``sides``."""
        f = living_faces(state, self.sides)
        coh = state.coh
        intact = coh[state.cstate == 0]
        if intact.shape[0] == 0 or f.shape[0] == 0:
            return f
        keys = np.vstack([np.sort(intact[:, :4], axis=1), np.sort(intact[:, 4:], axis=1)])
        fk = np.sort(f[:, :4], axis=1)
        both = np.vstack([keys, fk])
        _, inv = np.unique(both, axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        held = np.isin(inv[keys.shape[0]:], inv[:keys.shape[0]])
        return f[~held]

    def needs_rebuild(self, state) -> bool:
        """True once an element was deleted or a cohesive element debonded since the last rebuild (before,
        nothing can separate and there is no contact to look for)."""
        key = self.state_key(state)
        if key == self.key:
            return False
        return key[0] != state.alive.shape[0] or key[1] > 0

    def grow(self, state) -> bool:
        need = int(state.fr_par[FR_NEED])
        if need > state.fr_cent.shape[0]:
            state.fr_cent = np.empty(need, np.int64)
            state.fr_par[FR_NEED] = 0.0
            return True
        return False

    def rebuild(self, state) -> None:
        t0 = time.perf_counter()
        self.key = self.state_key(state)
        self.rebuilds += 1
        f = self.exposed(state)
        x = state.x
        nodes = np.unique(f[:, :4])
        if f.shape[0]:
            e = x[:, f[:, 1]] - x[:, f[:, 0]]
            cell = 2.0 * max(float(np.median(np.sqrt((e * e).sum(axis=0)))), 1e-12)
        else:
            cell = 1.0
        # over the exposed nodes, and at most the body's size beyond its initial box (a piece flung far
        # shares the border cells instead of stretching the grid)
        ext = x[:, nodes] if nodes.size else x
        X0 = state.X0
        size = float(np.ptp(X0, axis=1).max())
        lo = np.maximum(ext.min(axis=1), X0.min(axis=1) - size) - cell
        hi = np.minimum(ext.max(axis=1), X0.max(axis=1) + size) + cell
        hi = np.maximum(hi, lo + cell)
        while np.prod((hi - lo) / cell + 1) > (1 << 20):
            cell *= 1.5
        n = [int((hi[d] - lo[d]) / cell) + 2 for d in range(3)]
        par = np.zeros(N_FR)
        par[0:3] = lo
        par[FR_CELL] = cell
        par[FR_N:FR_N + 3] = n
        par[FR_K] = self.k_pen
        par[FR_PAD] = 0.25 * cell
        par[FR_DEEP] = state.fr_par[FR_DEEP]
        par[FR_WORK] = state.fr_par[FR_WORK]
        state.fr_faces = np.ascontiguousarray(np.hstack([f[:, :4], state.hexes[f[:, 4]]]), dtype=np.int64)
        state.fr_nodes = nodes.astype(np.int64)
        state.fr_par = par
        state.fr_cstart = np.zeros(n[0] * n[1] * n[2] + 1, np.int64)
        state.fr_cent = np.empty(max(8 * f.shape[0], 16), np.int64)
        self.seconds += time.perf_counter() - t0


# ------------------------------------------------------------------------------ state set-up
def no_tool(state) -> None:
    """The contact fields of a state without a rigid body (empty arrays: the contact phase is skipped)."""
    n = state.x.shape[1]
    state.tool = np.zeros(0)
    state.tool_par = np.zeros(3)
    state.fcon = np.zeros((3, n))
    state.fconp = np.zeros((3, n))
    state.tool_now = np.zeros(N_OUT)
    state.tool_out = np.zeros(N_OUT)
    state.tool_en = np.zeros(7)
    state.dt_contact = math.inf


def _set_body(state, body, kind, mu, dt, alpha):
    if state.steps:
        raise ValueError("add_tool / add_sphere: before the first step")
    if not mu >= 0:
        raise ValueError(f"mu = {mu}: must be >= 0")
    if not alpha > 0:
        raise ValueError(f"alpha = {alpha}: must be > 0")
    no_tool(state)
    if dt is None:
        dt = state.cfl * min(state.dt_crit, state.dt_cohesive)
    k = float(alpha) / float(dt) ** 2
    state.tool = np.ascontiguousarray(body, dtype=np.float64)
    state.tool_par = np.array([float(kind), k, float(mu)])
    state.dt_contact = 2.0 / math.sqrt(k)  # a node on its contact spring: omega dt < 2


def add_tool(state, tool, mu: float = 0.0, dt: float | None = None, alpha: float = TOOL_ALPHA) -> None:
    """Put the 2D tool (:func:`solver.tool.tool_array`'s array, moving with its velocity [2], [3]) extruded
    along z into the state, before the first step (and after :func:`solver.fem3d.loop.add_cohesive`, whose
    elements can lower the step). Penalty k_i = alpha m_i / dt^2 with dt the state's stable step (default),
    Coulomb friction mu."""
    tool = np.asarray(tool, dtype=np.float64)
    if tool.shape != (N_BODY,):
        raise ValueError(f"tool: need solver.tool.tool_array's ({N_BODY},) array, got {tool.shape}")
    _set_body(state, tool.copy(), KIND_TOOL, mu, dt, alpha)


def add_sphere(state, centre, radius: float, velocity=(0.0, 0.0, 0.0), mu: float = 0.0, dt: float | None = None,
               alpha: float = TOOL_ALPHA) -> None:
    """Put a rigid sphere (centre [m], radius [m], velocity [m/s]) into the state, before the first step;
    the same penalty and friction as :func:`add_tool`."""
    if not radius > 0:
        raise ValueError(f"radius = {radius}: must be > 0")
    b = np.zeros(N_BODY)
    b[0], b[1], b[5] = centre
    b[2], b[3], b[6] = velocity
    b[4] = radius
    _set_body(state, b, KIND_SPHERE, mu, dt, alpha)


def set_body_velocity(state, vx: float, vy: float, vz: float = 0.0) -> None:
    """The rigid body's velocity from now on (the extruded tool's z-velocity is always 0)."""
    state.tool[2] = vx
    state.tool[3] = vy
    if int(state.tool_par[0]) == KIND_SPHERE:
        state.tool[6] = vz
    elif vz != 0.0:
        raise ValueError("the extruded tool moves in the x-y plane only")


def symmetry_plane(state, axis: int, coord: float, tol: float | None = None) -> np.ndarray:
    """Hold the nodes on the plane x_axis = coord along that axis (no motion normal to the plane: a plane
    of symmetry); returns their ids. tol: distance counted as on the plane (default 1e-9 x the mesh size)."""
    X = state.X0
    if tol is None:
        tol = 1e-9 * float(np.ptp(X, axis=1).max())
    on = np.nonzero(np.abs(X[axis] - coord) <= tol)[0]
    if on.size == 0:
        raise ValueError(f"no node on the plane x[{axis}] = {coord:g}")
    state.fix[axis, on] = 1
    state.vp[axis, on] = 0.0
    return on


def strip_sides(state) -> tuple[np.ndarray, np.ndarray]:
    """Hold both sides of a strip, z = z0 and z = z1 (the extreme z of the mesh), along z: plane strain."""
    z = state.X0[2]
    return symmetry_plane(state, 2, float(z.min())), symmetry_plane(state, 2, float(z.max()))


def strip_width(state) -> float:
    """The strip's width along z [m] (to express forces per metre of width, as the 2D engine does)."""
    return float(np.ptp(state.X0[2]))


def tool_force_by_face(state, per_width: bool = True) -> dict:
    """The mean force on the tool over the steps taken, by face (rake, edge, clearance) and in total [N, or
    N/m of strip width with ``per_width``]."""
    n = max(state.steps, 1)
    w = strip_width(state) if per_width else 1.0
    o = state.tool_out / (n * w)
    out = {"total": o[0:3].copy()}
    for f, name in enumerate(("rake", "edge", "clearance")):
        out[name] = o[5 + 3 * f:8 + 3 * f].copy()
    return out


def contact_energies(state) -> dict:
    """The rigid body's terms of the energy balance [J]: its work on the workpiece (``tool_work``, part of
    the external work), the energy in the penalty springs (``contact``) and the friction's dissipation."""
    te = state.tool_en
    return {"tool_work": float(te[0]), "contact": float(te[0] - te[1] - te[2]), "friction": float(te[2])}
