"""Tool geometry (exact signed distance against a dense reference) and the tool contact kernel."""

import math

import numpy as np
import pytest
from matplotlib.path import Path as MplPath

from solver import load_scene
from solver.contact import tool_contact
from solver.tool import min_x_over_band, tool_array, tool_polygon, tool_sdf, tool_sdf_many


def make_tool(rake=30.0, clearance=7.0, radius=20.0):
    scene = load_scene("seed-0deg-fem-quick", {"tool.rake_angle_deg": rake, "tool.clearance_angle_deg": clearance,
                                               "tool.edge_radius_um": radius})
    return scene.si(), tool_array(scene.si())


def reference_sd(tool, px, py, length=2e-3):
    """Signed distance to a densely sampled closed outline (independent of tool_sdf's algebra)."""
    poly = tool_polygon(tool, length, n_arc=4000)
    # close the wedge far away, densify the straight faces
    dense = []
    for a, b in zip(poly[:-1], poly[1:]):
        for s in np.linspace(0, 1, 2 + int(np.hypot(*(b - a)) / 2e-8), endpoint=False):
            dense.append(a + s * (b - a))
    dense.append(poly[-1])
    dense = np.array(dense)
    closed = np.vstack([poly, poly[-1] + [0, length], poly[0] + [length, 0]])
    inside = MplPath(closed).contains_points(np.stack([px, py], 1))
    d = np.min(np.hypot(px[:, None] - dense[None, :, 0], py[:, None] - dense[None, :, 1]), axis=1)
    return np.where(inside, -d, d)


@pytest.mark.parametrize("rake,clearance,radius", [(30, 7, 20), (10, 7, 20), (-10, 11, 5), (0, 6, 0.0)])
def test_signed_distance_matches_a_dense_reference(rake, clearance, radius):
    si, tool = make_tool(rake, clearance, radius)
    rng = np.random.default_rng(1)
    cx, cy = tool[0], tool[1]
    px = cx + rng.uniform(-60e-6, 60e-6, 400)
    py = cy + rng.uniform(-60e-6, 60e-6, 400)
    sd, nx, ny = np.empty(400), np.empty(400), np.empty(400)
    tool_sdf_many(px, py, tool, sd, nx, ny)
    ref = reference_sd(tool, px, py)
    assert np.max(np.abs(sd - ref)) < 5e-8  # 0.05 um against a 20 nm-sampled outline
    assert np.allclose(np.hypot(nx, ny), 1.0)
    # the normal is the gradient of the distance: stepping along it changes sd by the step
    step = 1e-8
    sd2 = np.empty(400)
    tool_sdf_many(px + step * nx, py + step * ny, tool, sd2, np.empty(400), np.empty(400))
    assert np.allclose(sd2 - sd, step, atol=1e-11)


def test_arc_lowest_point_is_on_the_cut_plane_and_tool_starts_clear():
    si, tool = make_tool()
    ys = np.array([tool[1] - tool[4]])
    sd = np.empty(1)
    tool_sdf_many(np.array([tool[0]]), ys, tool, sd, np.empty(1), np.empty(1))
    assert abs(sd[0]) < 1e-15 and math.isclose(ys[0], -si.depth)
    assert tool[2] < 0 and tool[3] == 0
    assert min_x_over_band(tool, -si.height, 0.0) == pytest.approx(si.length + 0.5 * si.element_size)


def test_contact_force_is_penalty_times_penetration_along_the_normal():
    si, tool = make_tool(radius=20.0)
    k, g = 1e12, 0.3e-6
    # a node straight below the arc centre, pushed up into the arc by g: normal (0, -1)
    px, py = np.array([tool[0]]), np.array([tool[1] - tool[4] + g])
    v = np.zeros(1)
    fx, fy, out = np.zeros(1), np.zeros(1), np.zeros(4)
    tool_contact(px, py, v, v, np.ones(1), np.ones(1, np.uint8), tool, k, 0.0, fx, fy, out)
    assert fx[0] == pytest.approx(0.0, abs=1e-9 * k * g) and fy[0] == pytest.approx(-k * g, rel=1e-9)
    assert out[2] == pytest.approx(g, rel=1e-9)
    assert out[0] == pytest.approx(-fx[0]) and out[1] == pytest.approx(-fy[0])  # reaction on the tool
    # a node on the rake face: force along the rake normal (-cos a, sin a)
    a = si.rake
    n = np.array([-math.cos(a), math.sin(a)])
    tr = np.array([tool[0], tool[1]]) + tool[4] * n
    p = tr + 30e-6 * np.array([math.sin(a), math.cos(a)]) - g * n
    fx, fy, out = np.zeros(1), np.zeros(1), np.zeros(4)
    tool_contact(p[:1], p[1:], v, v, np.ones(1), np.ones(1, np.uint8), tool, k, 0.0, fx, fy, out)
    assert np.allclose([fx[0], fy[0]], k * g * n, rtol=1e-6)


def test_penalty_scales_with_the_node_mass_so_every_node_has_the_same_contact_period():
    """f_N = k_mass m_i g: a node four times heavier at the same penetration feels four times the force,
    so under the same acceleration both sink equally deep, and the penalty's own stable step
    2 / sqrt(k_mass) is the same for every node (it never limits a heavy node more than a light one)."""
    si, tool = make_tool(radius=20.0)
    k_mass, g = 1e20, 0.3e-6
    m = np.array([1e-9, 4e-9])
    px, py = np.array([tool[0]] * 2), np.array([tool[1] - tool[4] + g] * 2)
    fx, fy, out = np.zeros(2), np.zeros(2), np.zeros(4)
    tool_contact(px, py, np.zeros(2), np.zeros(2), m, np.ones(2, np.uint8), tool, k_mass, 0.0, fx, fy, out, 1)
    assert fy[1] == pytest.approx(4.0 * fy[0], rel=1e-12) and fy[0] == pytest.approx(-k_mass * m[0] * g, rel=1e-9)
    # a free node dropped onto the arc at the engine's step: its bounce is stable whatever its mass
    from solver.contact import contact_stiffness
    dt = 1e-10
    km = contact_stiffness(1.0, dt)  # per unit mass: 0.1 / dt^2
    for mass in (1e-12, 1e-6):
        x, y = np.array([tool[0]]), np.array([tool[1] - tool[4] - 1e-8])
        vx, vy = np.array([tool[2]]), np.array([100.0])  # moving with the tool along x, up into the arc
        depth = 0.0
        for _ in range(400):
            f1, f2, o = np.zeros(1), np.zeros(1), np.zeros(4)
            tool_contact(x, y, vx, vy, np.array([mass]), np.ones(1, np.uint8), tool, km, 0.0, f1, f2, o, 1)
            vy += dt * f2 / mass
            y += dt * vy
            depth = max(depth, o[2])
        # it bounced back out at (nearly) its impact speed, and sank v / sqrt(k_mass) (the spring's amplitude)
        assert vy[0] == pytest.approx(-100.0, rel=0.05)
        assert depth == pytest.approx(100.0 / math.sqrt(km), rel=0.1)


def test_friction_opposes_slip_and_is_capped_by_mu_fn():
    si, tool = make_tool()
    k, g, mu = 1e12, 0.2e-6, 0.3
    px, py = np.array([tool[0]] * 3), np.array([tool[1] - tool[4] + g] * 3)
    # slip relative to the tool along x: slow, fast, and none
    vx = tool[2] + np.array([1e-6, 50.0, 0.0])
    vy = np.zeros(3)
    fx, fy, out = np.zeros(3), np.zeros(3), np.zeros(4)
    tool_contact(px, py, vx, vy, np.ones(3), np.ones(3, np.uint8), tool, k, mu, fx, fy, out)
    fn = k * g
    assert np.all(np.abs(fx) <= mu * fn * (1 + 1e-12))
    assert fx[1] == pytest.approx(-mu * fn, rel=1e-3)  # fast slip: full Coulomb, opposing +x slip
    assert 0 > fx[0] > -mu * fn and fx[2] == 0.0  # slow slip is regularised, no slip no friction
    assert out[3] > 0 and out[3] == pytest.approx(-(fx * (vx - tool[2])).sum(), rel=1e-9)
    assert out[0] == pytest.approx(-fx.sum()) and out[1] == pytest.approx(-fy.sum())


def test_inactive_and_clear_nodes_get_nothing():
    si, tool = make_tool()
    px = np.array([tool[0], tool[0] - tool[4] - 1e-6])
    py = np.array([tool[1] - tool[4] + 1e-7, tool[1]])
    fx, fy, out = np.zeros(2), np.zeros(2), np.zeros(4)
    tool_contact(px, py, np.zeros(2), np.zeros(2), np.ones(2), np.array([0, 1], np.uint8), tool, 1e12, 0.3, fx, fy, out)
    assert np.all(fx == 0) and np.all(fy == 0) and np.all(out == 0)


def _two_squares():
    """Two unit squares (two parts); the upper one's bottom-left node dips 0.1 below the lower one's top."""
    from types import SimpleNamespace

    from solver.fem.state import no_fragments

    x = np.array([0, 1, 1, 0, 0.3, 1.3, 1.3, 0.3], float) * 1e-6
    y = np.array([0, 0, 1, 1, 0.9, 0.9, 1.9, 1.9], float) * 1e-6
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]], np.int32)
    st = SimpleNamespace(x=x, y=y, X0=x.copy(), Y0=y.copy(), alive=np.ones(2, np.uint8))
    no_fragments(st, 8)
    return st, quads


def _step(st, vx, vy, dtprev):
    from solver.contact import fragment_contact_step

    fragment_contact_step(st.x, st.y, vx, vy, dtprev, st.fr_edges, st.fr_enodes, st.fr_nodes, st.alive,
                          np.ones(st.x.size, np.uint8), st.fr_grid,
                          st.fr_cstart, st.fr_cent, st.fr_depth, st.ffx, st.ffy, st.fr_out)
    return st.ffx, st.ffy


def test_fragment_contact_pushes_a_node_that_crossed_out_and_conserves_momentum():
    from solver.contact import FragmentContact

    st, quads = _two_squares()
    fc = FragmentContact(quads, 8, k_pen=1e12)
    fc.rebuild(st)
    assert len(st.fr_edges) == 8 and st.fr_on == 1
    # the upper square came down by 0.2 um in the last step: its penetration of 0.1 um is a crossing
    vy = np.array([0, 0, 0, 0, -1, -1, -1, -1], float)
    fx, fy = _step(st, np.zeros(8), vy, 0.2e-6)
    # node 4 is pushed up by its own penetration (k g) and carries 30 % of the reaction of node 2,
    # which dips 0.1 into the upper square's bottom edge at s = 0.7 (and symmetrically for node 2)
    assert fy[4] == pytest.approx(1.3e12 * 0.1e-6, rel=1e-6) and fx[4] == pytest.approx(0.0, abs=1e-3)
    assert fy[2] == pytest.approx(-1.3e12 * 0.1e-6, rel=1e-6)
    assert fy[5] == pytest.approx(0.7e12 * 0.1e-6, rel=1e-6)  # node 5 only carries 70 % of node 2's reaction
    assert abs(fx.sum()) < 1e-9 and abs(fy.sum()) < 1e-9  # action = reaction
    assert fy[3] < 0  # the reaction goes to the edge's nodes
    assert st.fr_out[0] == pytest.approx(0.1e-6) and st.fr_out[1] == 2
    # in contact, the node stays held at rest (its depth is remembered)
    fx, fy = _step(st, np.zeros(8), np.zeros(8), 0.2e-6)
    assert fy[4] == pytest.approx(1.3e12 * 0.1e-6, rel=1e-6)
    # a deleted element leaves no edges, and a lone square never contacts its own edges
    st.alive = np.array([1, 0], np.uint8)
    fc.rebuild(st)
    assert len(st.fr_edges) == 4
    fx, fy = _step(st, np.zeros(8), vy, 0.2e-6)
    assert np.all(fx == 0) and np.all(fy == 0)


def test_a_node_no_element_holds_does_not_stretch_the_fragment_grid():
    """A node whose elements are all gone keeps drifting with its last velocity (in the hybrid it has
    given its mass to particles); it is no contact surface, so the fragment grid spans the exposed
    nodes only, and a living piece thrown far is binned into the border cells of a grid at most the
    workpiece's size beyond its initial box (once, a massless node at 14 km/s made 1e6 cells)."""
    from solver.contact import FragmentContact

    st, quads = _two_squares()
    fc = FragmentContact(quads, 8, k_pen=1e12)
    fc.rebuild(st)
    cells = int(st.fr_grid[3] * st.fr_grid[4])
    st.x = np.append(st.x, [-5e-3, -5e-3 + 1e-6, -5e-3 + 1e-6, -5e-3])  # a third square, dead, 5 mm away
    st.y = np.append(st.y, [0.0, 0.0, 1e-6, 1e-6])
    st.X0 = np.append(st.X0, [2e-6, 3e-6, 3e-6, 2e-6])
    st.Y0 = np.append(st.Y0, [0.0, 0.0, 1e-6, 1e-6])
    quads3 = np.vstack([quads, [[8, 9, 10, 11]]]).astype(np.int32)
    st.alive = np.array([1, 1, 0], np.uint8)
    from solver.fem.state import no_fragments

    no_fragments(st, 12)
    FragmentContact(quads3, 12, k_pen=1e12).rebuild(st)
    assert int(st.fr_grid[3] * st.fr_grid[4]) == cells
    st.alive = np.array([1, 1, 1], np.uint8)  # alive: a contact surface, clamped to 3 um beyond the box
    FragmentContact(quads3, 12, k_pen=1e12).rebuild(st)
    assert st.fr_grid[0] >= -3e-6 - 2 * st.fr_grid[2] and int(st.fr_grid[3] * st.fr_grid[4]) < 10 * cells


def test_fragment_contact_holds_apart_the_faces_of_one_body():
    """Self-contact: the two squares joined by a third element far from the touching faces are one
    connected part (as fibre and matrix strips are through the homogeneous material), and the upper
    square's dipping node is still pushed out of the lower one."""
    from solver.contact import FragmentContact, connected_parts

    st, quads = _two_squares()
    st.x = np.append(st.x, [2e-6, 2e-6])
    st.y = np.append(st.y, [0.0, 0.9e-6])
    quads = np.vstack([quads, [[1, 8, 9, 5]]]).astype(np.int32)
    st.alive = np.ones(3, np.uint8)
    from solver.fem.state import no_fragments

    no_fragments(st, 10)
    assert np.unique(connected_parts(quads, st.alive, 10)).size == 1
    FragmentContact(quads, 10, k_pen=1e12).rebuild(st)
    vy = np.where(np.arange(10) >= 4, -1.0, 0.0)
    vy[[8]] = 0.0
    fx, fy = _step(st, np.zeros(10), vy, 0.2e-6)
    assert fy[4] > 0 and fy[2] < 0  # node 4 pushed up out of the lower square, node 2 down out of the upper
    assert abs(fx.sum()) < 1e-9 and abs(fy.sum()) < 1e-9
    assert st.fr_out[1] == 2  # nodes 4 and 2; no node of an element pushes against that element's edges


def test_fragment_contact_leaves_out_faces_of_intact_interfaces():
    """Two squares tied by a cohesive element along their shared face (duplicate nodes): while the
    cohesive is intact its faces are not contact surfaces (the cohesive holds them); once it debonds
    they are, and the change asks for a rebuild."""
    from types import SimpleNamespace

    from solver.contact import FragmentContact
    from solver.fem.state import no_fragments

    x = np.array([0, 1, 1, 0, 1, 2, 2, 1], float) * 1e-6
    y = np.array([0, 0, 1, 1, 0, 0, 1, 1], float) * 1e-6
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]], np.int32)
    st = SimpleNamespace(x=x, y=y, X0=x.copy(), Y0=y.copy(), alive=np.ones(2, np.uint8), coh=np.array([[1, 2, 4, 7]], np.int32),
                         cstate=np.zeros(1, np.int8))
    no_fragments(st, 8)
    fc = FragmentContact(quads, 8, k_pen=1e12)
    assert not fc.needs_rebuild(st)  # nothing failed yet: no contact arrays at all
    fc.rebuild(st)
    faces = {tuple(sorted(e[:2])) for e in st.fr_edges}
    assert len(st.fr_edges) == 6 and (1, 2) not in faces and (4, 7) not in faces
    assert not fc.needs_rebuild(st)
    st.cstate[0] = 1  # debonded
    assert fc.needs_rebuild(st)
    fc.rebuild(st)
    faces = {tuple(sorted(e[:2])) for e in st.fr_edges}
    assert len(st.fr_edges) == 8 and (1, 2) in faces and (4, 7) in faces


def test_fragment_contact_leaves_a_node_it_did_not_see_cross():
    """A node found 0.1 um deep with no motion that could have put it there (a freshly exposed surface's
    geometry) is not launched by the penalty."""
    from solver.contact import FragmentContact

    st, quads = _two_squares()
    FragmentContact(quads, 8, k_pen=1e12).rebuild(st)
    fx, fy = _step(st, np.zeros(8), np.zeros(8), 1e-9)
    assert np.all(fx == 0) and np.all(fy == 0) and st.fr_out[1] == 0


def test_mirrored_tool_mirrors_distance_and_normal():
    from solver.tool import mirrored

    si, tool = make_tool()
    mt = mirrored(tool, 0.0)
    rng = np.random.default_rng(2)
    px = tool[0] + rng.uniform(-50e-6, 50e-6, 200)
    py = tool[1] + rng.uniform(-50e-6, 50e-6, 200)
    a = [np.empty(200) for _ in range(3)]
    b = [np.empty(200) for _ in range(3)]
    tool_sdf_many(px, py, tool, *a)
    tool_sdf_many(-px, py, mt, *b)
    assert np.allclose(a[0], b[0]) and np.allclose(a[1], -b[1]) and np.allclose(a[2], b[2])


@pytest.mark.parametrize("radius", [20.0, 0.0])
def test_the_force_splits_by_the_face_it_acts_on_and_the_parts_add_up(radius):
    """out[4:10] of a 10-entry out array: the reaction from the rake face, the cutting edge and the clearance
    face apart. A node pressed into the rake face, one into the clearance face and one under the arc's lowest
    point each land in their own part; the parts add up to the total (out[0:2]). A sharp tool has no edge
    surface: a node pressed in at its apex is on the face it is nearer to."""
    si, tool = make_tool(rake=10.0, clearance=7.0, radius=radius)
    a, gam, r, g = si.rake, si.clearance, tool[4], 0.2e-6
    c = np.array([tool[0], tool[1]])
    n_r, t_r = np.array([-math.cos(a), math.sin(a)]), np.array([math.sin(a), math.cos(a)])
    n_c, t_c = np.array([math.sin(gam), -math.cos(gam)]), np.array([math.cos(gam), math.sin(gam)])
    p = np.array([c + r * n_r + 10e-6 * t_r - g * n_r,  # rake face
                  c + r * n_c + 10e-6 * t_c - g * n_c,  # clearance face
                  c + (r - g) * np.array([0.0, -1.0]) if r > 0 else c + 0.5 * g * (t_r + t_c)])  # under the arc / apex
    fx, fy, out = np.zeros(3), np.zeros(3), np.zeros(10)
    tool_contact(p[:, 0], p[:, 1], np.zeros(3), np.zeros(3), np.ones(3), np.ones(3, np.uint8), tool, 1e12, 0.0, fx, fy,
                 out)
    assert np.all(fx ** 2 + fy ** 2 > 0)  # all three in contact
    # without friction a positive-rake face pushes the tool down, the clearance face up (with friction the
    # chip sliding up the rake face pulls the tool up: Merchant's Ft = R sin(beta - alpha))
    assert out[5] < 0 < out[9]
    if radius > 0:
        assert out[4] == pytest.approx(-fx[0]) and out[5] == pytest.approx(-fy[0])  # rake
        assert out[8] == pytest.approx(-fx[1]) and out[9] == pytest.approx(-fy[1])  # clearance
        assert out[6] == pytest.approx(-fx[2]) and out[7] == pytest.approx(-fy[2]) and out[7] > 0  # edge, up
    else:
        assert out[6] == 0.0 and out[7] == 0.0
    assert out[4] + out[6] + out[8] == pytest.approx(out[0], rel=1e-12)
    assert out[5] + out[7] + out[9] == pytest.approx(out[1], rel=1e-12)


def _stick(dt_in_law: float, n: int = 300):
    """A free node (unit mass) pressed 2 nm into the underside of the edge, at rest while the tool slides
    along x at 18 m/s: central differences of the tangential motion under the tool's friction.
    Returns the slip speeds of every step and the friction's dissipation over the last half of the steps."""
    si, tool = make_tool()
    tool = tool.copy()
    tool[2], tool[3] = -18.0, 0.0
    dt, mu = 1e-10, 0.3
    k_mass = 1.0 / dt**2  # TOOL_ALPHA m / dt^2 per unit mass: omega dt = 1
    px, py = np.array([tool[0]]), np.array([tool[1] - tool[4] + 2e-9])
    vx, vy = np.zeros(1), np.zeros(1)
    slips, power = [], []
    for _ in range(n):
        fx, fy, out = np.zeros(1), np.zeros(1), np.zeros(4)
        tool_contact(px, py, vx, vy, np.ones(1), np.ones(1, np.uint8), tool, k_mass, mu, fx, fy, out, 1, dt_in_law)
        vx += dt * fx          # the normal motion is held: only the slip is integrated
        px += dt * vx
        tool[0] += dt * tool[2]
        slips.append(vx[0] - tool[2])
        power.append(out[3])
    return np.array(slips), float(np.sum(power[n // 2:]) * dt)


def test_friction_lets_a_node_stick_instead_of_chattering():
    """The friction's impulse in one step (mu a_N dt = 6 m/s here, a_N = g / dt^2) must not exceed the slip it
    stops: capped at that (solver.contact.friction_scale) the node catches up with the tool without its slip
    changing sign and then dissipates next to nothing; with the regularised law alone (eps = 1e-3 |v_tool|)
    its slip flips at every step and the friction keeps dissipating at mu a_N |v_t| once it should stick."""
    slips, late = _stick(dt_in_law=1e-10)
    assert np.all(slips >= -1e-12)                      # it never overtakes the tool
    assert abs(slips[-1]) < 1e-2                        # it sticks (it creeps along the edge's curve)
    assert late < 1e-5 * 0.5 * 18.0**2                  # and sticking dissipates next to nothing
    old, late_old = _stick(dt_in_law=0.0)
    assert np.sum(np.diff(np.sign(old[150:])) != 0) > 100  # the unfloored law chatters
    assert late_old > 1e3 * late


def _pushed(dt: float, ratio: float, trial_sees_push: bool, n: int = 200):
    """A free node (unit mass) pressed into the underside of the edge of a tool at rest with a normal force
    f_N, and pushed along x by another force ratio x mu f_N: central differences of the tangential motion.
    Returns the slip speed after every step, the push, and each step's friction and normal force. The
    penalty is held (f_N the same at every dt)."""
    si, tool = make_tool()
    tool = tool.copy()
    tool[2], tool[3] = 0.0, 0.0
    mu, k_mass, g = 0.3, 1e20, 2e-9  # f_N = k g = 2e11 N per unit mass
    push = ratio * mu * k_mass * g
    px, py = np.array([tool[0]]), np.array([tool[1] - tool[4] + g])
    vx = np.zeros(1)
    fox, foy = np.array([push]), np.zeros(1)
    slips, f_t, f_n = [], [], []
    for _ in range(n):
        fx, fy, out = np.zeros(1), np.zeros(1), np.zeros(4)
        _, nx, ny = tool_sdf(px[0], py[0], tool)
        tool_contact(px, py, vx, np.zeros(1), np.ones(1), np.ones(1, np.uint8), tool, k_mass, mu, fx, fy, out, 1, dt,
                     *((fox, foy) if trial_sees_push else (None, None)))
        f_n.append(fx[0] * nx + fy[0] * ny)
        f_t.append(-fx[0] * ny + fy[0] * nx)
        vx += dt * (push + fx)  # the normal motion is held: only the slip is integrated
        px += dt * vx
        slips.append(vx[0])
    return np.array(slips), push, np.array(f_t), np.array(f_n)


@pytest.mark.parametrize("dt", [1e-10, 0.5e-10])
def test_a_node_pushed_along_the_face_below_coulombs_limit_sticks_at_any_step(dt):
    """Coulomb's law: a push below mu f_N is held by friction, the node does not move along the face. The
    stick/slip trial that includes the push (solver.contact.friction_scale) holds it exactly; a trial that
    stops only the slip the node already has lets it creep at dt f_t / m, a drift that halves with the step
    (here 3 m/s at dt = 0.1 ns, the quick 0-degree scene's chip slid up the rake face so)."""
    slips, push, _, _ = _pushed(dt, 0.5, trial_sees_push=True)
    assert np.abs(slips).max() <= 1e-12 * dt * push
    creep, _, _, _ = _pushed(dt, 0.5, trial_sees_push=False)
    assert creep[-1] == pytest.approx(dt * push, rel=0.05)  # (the edge curves under the creeping node)


@pytest.mark.parametrize("dt", [1e-10, 0.5e-10])
def test_a_node_pushed_past_coulombs_limit_slides_against_mu_fn(dt):
    """Past Coulomb's limit the node slides, against a friction of mu f_N at every step whatever the step."""
    slips, push, f_t, f_n = _pushed(dt, 2.0, trial_sees_push=True, n=8)  # (then it has slid off the edge)
    assert np.all(np.diff(slips) > 0)
    np.testing.assert_allclose(np.abs(f_t), 0.3 * f_n, rtol=1e-9)
    assert np.all(f_t < 0)  # against the slip (+x; the tangent (-n_y, n_x) is +x under the edge)
