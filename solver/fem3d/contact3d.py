"""Contact in the 3D hexahedral engine: a rigid body (the cutting tool, or a sphere) against the nodes, and
the symmetry planes of a strip.

The tool in 3D is the 2D tool's profile (:mod:`solver.tool`: rake face, edge arc, clearance face) extruded
along z across the strip: a node's signed distance and outward normal are the 2D tool's at its (x, y)
(:func:`solver.tool.tool_sdf`, the same compiled function the 2D engine uses), with a zero z-component
of the normal. The sphere (:func:`sphere_sdf`, for Hertz's point contact) is the other rigid body.

Penalty and friction (:func:`rigid_contact3d`), as the 2D engine's :func:`solver.contact.tool_contact`
in three components: a node of mass m_i at penetration g = -sd > 0 with outward normal n gets

    f_N = k m_i g n,   k = TOOL_ALPHA / dt^2                   (solver.contact.TOOL_ALPHA)
    v_t = (v - v_body) - ((v - v_body) . n) n                (slip velocity)
    f_T = -mu |f_N| v_t / sqrt(|v_t|^2 + eps^2),  eps = 1e-3 |v_body| + 1e-9 m/s

(regularised Coulomb friction, Oden & Martins 1985). Where a node should stick, the explicit step can
make it chatter: the friction's impulse in one step, mu k m g dt = mu TOOL_ALPHA g / dt per unit mass, can
exceed the slip speed, and the force flips from step to step (the 2D law does the same; the verification's
sliding case keeps mass-proportional damping on, docs/numerics.md). The forces are those of the 2D tool per node; in
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

Contact between separated fragments (the 2D engine's :func:`solver.contact.fragment_contact_step`) does
not exist in 3D yet.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..contact import TOOL_ALPHA
from ..tool import tool_face, tool_sdf

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
def rigid_contact3d(x, v, mass, body, kind, k, mu, fcon, out):
    """Penalty contact and regularised Coulomb friction of a rigid body against every node (module
    docstring): forces into fcon (3, n) (overwritten), this step's totals into out (:data:`N_OUT`,
    overwritten). kind 0: the 2D tool extruded along z (:func:`solver.tool.tool_sdf` of (x, y)), 1: a
    sphere (:func:`sphere_sdf`). Cost linear in the number of nodes."""
    for j in range(out.shape[0]):
        out[j] = 0.0
    vbx = body[2]
    vby = body[3]
    vbz = body[6] if kind == KIND_SPHERE else 0.0
    eps = 1e-3 * math.sqrt(vbx * vbx + vby * vby + vbz * vbz) + 1e-9
    for i in range(x.shape[1]):
        fcon[0, i] = 0.0
        fcon[1, i] = 0.0
        fcon[2, i] = 0.0
        if kind == KIND_SPHERE:
            sd, nx, ny, nz = sphere_sdf(x[0, i], x[1, i], x[2, i], body)
        else:
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
        vt = math.sqrt(tx * tx + ty * ty + tz * tz)
        if mu > 0.0 and vt > 0.0:
            scale = mu * fn / math.sqrt(vt * vt + eps * eps)
            fx -= scale * tx
            fy -= scale * ty
            fz -= scale * tz
            out[4] += scale * vt * vt
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
