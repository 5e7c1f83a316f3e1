"""Particle - element-edge coupling (solver.sph.coupling) inside the compiled SPH step."""

import numpy as np
import pytest

from solver.contact import _build_cells
from solver.sph import loop, materials as mt, particles as pp
from solver.sph.coupling import bin_elements


#: the edges' element when a test needs only the penalty: a collapsed quad, inside which no point lies
NO_ELEMENT = np.array([[0, 1, 1, 0]], np.int32)


def _edge_contact(x, y, vx, vy, edges, k, r_c, v_sep, quads=NO_ELEMENT):
    cell = float(np.max(np.hypot(x[edges[:, 1]] - x[edges[:, 0]], y[edges[:, 1]] - y[edges[:, 0]]))) + r_c
    x0, y0 = float(x.min()) - cell, float(y.min()) - cell
    ncx, ncy = int((x.max() - x0) / cell) + 2, int((y.max() - y0) / cell) + 2
    estart, eitems = np.empty(ncx * ncy + 1, np.int64), np.empty(edges.shape[0], np.int64)
    _build_cells(x, y, edges, x0, y0, cell, ncx, ncy, estart, eitems)
    live = np.arange(quads.shape[0], dtype=np.int64)
    lstart, litems, lgrid = bin_elements(quads, live, x, y, 0.5e-6, x0, y0, x0 + ncx * cell, y0 + ncy * cell)
    return loop.EdgeContact(edges, quads, x, y, vx, vy, np.array([x0, y0, cell, ncx, ncy, k, r_c, v_sep, 0.0]), estart, eitems,
                            lgrid, lstart, litems)


def _two_squares(x_b):
    """Two 2-um square elements, A = [0, 2] x [0, 2] um and B = [x_b, x_b + 2 um] x [0, 2] um, every edge exposed:
    (x, y, quads, edges)."""
    um = 1e-6
    x = np.array([0.0, 2 * um, 2 * um, 0.0, x_b, x_b + 2 * um, x_b + 2 * um, x_b])
    y = np.array([0.0, 0, 2, 2, 0, 0, 2, 2]) * um
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]], np.int32)
    edges = np.array([[0, 1, 0], [1, 2, 0], [2, 3, 0], [3, 0, 0], [4, 5, 1], [5, 6, 1], [6, 7, 1], [7, 4, 1]], np.int32)
    return x, y, quads, edges


def _particle(px, py, dp=1e-6):
    mats = mt.table(mt.isotropic(3e9, 0.3, 1200.0))
    return pp.from_points([px], [py], mats, pp.make_params(dp))


def _square():
    """One 2-um square element [0, 2] x [0, 2] um, counter-clockwise, its four edges exposed: (x, y, quads, edges)."""
    x, y = np.array([0.0, 2, 2, 0]) * 1e-6, np.array([0.0, 0, 2, 2]) * 1e-6
    return x, y, np.array([[0, 1, 2, 3]], np.int32), np.array([[0, 1, 0], [1, 2, 0], [2, 3, 0], [3, 0, 0]], np.int32)


def _rake_face_tool(x_face, r=0.5e-6, clearance=0.1):
    """A rake-0 tool whose rake face is the line x = x_face [m] above its edge (radius r, centre 5 um below
    the origin), not mirrored (:func:`solver.tool.tool_array`'s layout)."""
    from solver.tool import N_TOOL

    tool = np.zeros(N_TOOL)
    tool[0], tool[1], tool[4], tool[5], tool[6] = x_face + r, -5e-6, r, 0.0, clearance
    tool[7], tool[8], tool[9], tool[10], tool[11] = 1.0, 0.0, np.cos(clearance), np.sin(clearance), 1.0
    return tool


@pytest.mark.parametrize("v_in,v_sep", [(2.0, 10.0), (20.0, 10.0)])
def test_a_particle_hitting_an_edge_bounces_off_and_the_contact_energy_closes(v_in, v_sep):
    """A particle thrown at a fixed 4 um edge (the body above it, outward normal down) with the cutting
    scene's penalty k = 0.1 m / dt^2. Slower than the separation speed it bounces back elastically: it
    leaves at its speed of impact and the coupling's work on it W_p is nothing, to 1.5e-2. Faster, the
    limit lets it leave at v_sep at most, its spring keeping the compression it cannot give back: the
    energy the particle lost is what the pair booked as held back, W_p + D_c + E_s = 0 to 1e-3 of the
    kinetic energy it came with. The nodes take the opposite impulse (momentum conserved)."""
    L, r_c, dt = 4e-6, 0.5e-6, 1e-10
    x, y = np.array([0.0, L]), np.array([0.0, 0.0])
    edges = np.array([[0, 1, 0]], np.int32)  # a -> b along +x: outward normal (dy, -dx) / L = (0, -1)
    P = _particle(0.5 * L, -r_c - 2 * v_in * dt)  # two steps short of the contact radius
    P.F[pp.VY, 0] = v_in
    m = float(P.F[pp.M, 0])
    k = 0.1 * m / dt**2
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), edges, k, r_c, v_sep)
    jy, speeds = 0.0, []
    for _ in range(100):
        assert loop.step_chunk(P, 4, dt, edges=ec).status == "ok"
        jy += ec.fyn.sum() * dt  # the reaction forces summed over the steps
        speeds.append(abs(P.F[pp.VY, 0]))
    pairs = P.scratch["edge_pairs"]
    assert P.F[pp.VY, 0] < 0 and P.F[pp.Y, 0] < -r_c and abs(P.F[pp.VX, 0]) < 1e-12  # back out, clear of the edge
    assert np.all(pairs[1::3, 0] == 0.0)  # the pair left reach and was dropped
    ke0 = 0.5 * m * v_in**2
    w_p, d_c = float(ec.out[2]), float(ec.out[3] + ec.expelled[6])
    assert 0.5 * m * P.F[pp.VY, 0] ** 2 - ke0 == pytest.approx(w_p, rel=1e-6, abs=1e-9 * ke0)  # the kicks' work
    if v_in < v_sep:  # measured: leaves 0.5 % faster, W_p = +1.0e-2 of the kinetic energy (the leapfrog's
        # error over a contact of about 20 steps that starts between two of them)
        assert -P.F[pp.VY, 0] == pytest.approx(v_in, rel=1e-2) and abs(w_p) < 1.5e-2 * ke0 and d_c == 0.0
    else:  # measured: W_p + D_c = 2e-15 of it, D_c = 0.75 of it (the particle leaves at half its speed)
        assert max(speeds[len(speeds) // 2:]) <= v_sep * (1 + 1e-9) and d_c > 0.5 * ke0
        assert abs(w_p + d_c) < 1e-3 * ke0
    assert m * P.F[pp.VY, 0] - m * v_in == pytest.approx(-jy, rel=1e-9)  # the nodes' impulse balances the particle's


def test_a_particle_behind_an_edge_but_in_no_element_feels_nothing_from_it():
    """Behind an edge's line (0.3 um, within its span) but inside no living element: past a corner of
    the body or across a thin piece, not this edge's business. An earlier version's edge pushed particles
    up to half its length behind it, sideways past a corner."""
    x, y = np.array([0.0, 4e-6]), np.array([0.0, 0.0])
    P = _particle(2e-6, 0.3e-6)  # above the edge, on the body's side of it; NO_ELEMENT: in no element
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), np.array([[0, 1, 0]], np.int32), 1e12, 0.5e-6, 10.0)
    rep = loop.step_chunk(P, 20, 1e-10, edges=ec)
    assert rep.status == "ok" and P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    assert np.all(ec.fxn == 0) and np.all(ec.fyn == 0) and ec.out[1] == 0


def test_a_converted_particle_is_not_pushed_by_the_overlap_it_was_born_with():
    """A particle converted 0.2 um in front of an edge (r_c = 0.5 um: its spring 0.3 um compressed by no
    motion of its own) starts its contact unstrained (the pair's offset d0 = 0.3 um): at rest it stays at
    rest, where the spring alone would launch it. Moved 0.1 um further in, the spring pushes it back out
    with no more kinetic energy than those 0.1 um store, k (0.1 um)^2 / 2."""
    x, y = np.array([0.0, 4e-6]), np.array([0.0, 0.0])  # the body above, the outward normal down
    P = _particle(2e-6, -0.2e-6)  # its pair memory empty, as conversion leaves it
    k = 0.1 * float(P.F[pp.M, 0]) / 1e-10**2
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), np.array([[0, 1, 0]], np.int32), k, 0.5e-6, 10.0)
    rep = loop.step_chunk(P, 50, 1e-10, edges=ec)
    assert rep.status == "ok" and P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    pairs = P.scratch["edge_pairs"]
    assert pairs[1, 0] != 0.0 and pairs[2, 0] == pytest.approx(0.3e-6, rel=1e-9) and pairs[3, 0] == 0.0
    P.F[pp.Y, 0] = -0.1e-6  # pressed 0.1 um further in
    P.forces_valid = False
    loop.step_chunk(P, 500, 1e-10, edges=ec)
    assert P.F[pp.Y, 0] < -0.5e-6 and P.F[pp.VY, 0] < 0  # pushed back out, beyond r_c
    assert 0.5 * float(P.F[pp.M, 0]) * P.F[pp.VY, 0] ** 2 <= 0.5 * k * 0.1e-6**2


def test_a_particle_clear_of_the_edges_feels_nothing():
    x, y = np.array([0.0, 4e-6]), np.array([0.0, 0.0])
    P = _particle(2e-6, -2e-6)  # 2 um outside (below) the edge, beyond r_c
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), np.array([[0, 1, 0]], np.int32), 1e12, 0.5e-6, 10.0)
    rep = loop.step_chunk(P, 20, 1e-10, edges=ec)
    assert rep.status == "ok" and P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    assert np.all(ec.fxn == 0) and np.all(ec.fyn == 0) and ec.out[1] == 0


def test_a_particle_inside_an_element_is_put_in_front_of_its_nearest_edge_and_stops_going_in():
    """The kinematic condition (expel_from_elements): a particle 0.4 um inside a 2 um square element
    whose four edges are exposed, moving at (1, 2) m/s (into the element through its bottom edge), is
    put r_c = 0.5 um in front of the bottom edge after one step (where its new spring starts unstrained,
    with the whole contact radius to push back with), its normal velocity relative to the resting edge cancelled
    (a plastic impact: v = (1, 0)), its tangential velocity kept; the edge's nodes take the opposite
    impulse, and the kinetic energy the impact took is booked as the coupling's work on the particle."""
    L = 2e-6
    x, y = np.array([0.0, L, L, 0.0]), np.array([0.0, 0.0, L, L])
    quads = np.array([[0, 1, 2, 3]], np.int32)  # counter-clockwise
    edges = np.array([[0, 1, 0], [1, 2, 0], [2, 3, 0], [3, 0, 0]], np.int32)
    P = _particle(1e-6, 0.4e-6)
    P.F[pp.VX, 0], P.F[pp.VY, 0] = 1.0, 2.0
    m = float(P.F[pp.M, 0])
    ec = _edge_contact(x, y, np.zeros(4), np.zeros(4), edges, 0.0, 0.5e-6, 10.0, quads)  # no penalty
    rep = loop.step_chunk(P, 1, 1e-10, edges=ec)
    assert rep.status == "ok"
    assert P.F[pp.Y, 0] == pytest.approx(-0.5e-6, rel=1e-9)  # r_c in front of the bottom edge
    assert P.F[pp.X, 0] == pytest.approx(1e-6 + 1e-10, rel=1e-9)  # the drift along the edge, kept
    assert P.F[pp.VX, 0] == pytest.approx(1.0, rel=1e-12) and abs(P.F[pp.VY, 0]) < 1e-12
    # momentum: the nodes' impulse balances the particle's change (m dv = -2 m in y)
    assert ec.jyn.sum() == pytest.approx(2.0 * m, rel=1e-9) and abs(ec.jxn.sum()) < 1e-12 * m
    assert ec.jyn[0] == pytest.approx(ec.jyn[1], rel=1e-6)  # the foot is at the edge's middle
    assert ec.expelled[0] == 1 and ec.expelled[1] == pytest.approx(0.4e-6 + 2e-10, rel=1e-6)
    assert ec.expelled[2] == pytest.approx(0.5 * m * (1.0 - 5.0), rel=1e-9)


def test_a_particle_leaving_an_element_keeps_its_velocity():
    """Inside but already moving out through its nearest edge: put in front of it, velocity unchanged
    (the impact only stops a motion into the element), no impulse on the nodes."""
    L = 2e-6
    x, y = np.array([0.0, L, L, 0.0]), np.array([0.0, 0.0, L, L])
    quads = np.array([[0, 1, 2, 3]], np.int32)
    edges = np.array([[0, 1, 0], [1, 2, 0], [2, 3, 0], [3, 0, 0]], np.int32)
    P = _particle(1e-6, 0.3e-6)
    P.F[pp.VY, 0] = -3.0
    ec = _edge_contact(x, y, np.zeros(4), np.zeros(4), edges, 0.0, 0.5e-6, 10.0, quads)
    loop.step_chunk(P, 1, 1e-10, edges=ec)
    assert P.F[pp.Y, 0] <= 0.0 and P.F[pp.VY, 0] == -3.0 and P.F[pp.VX, 0] == 0.0
    assert np.all(ec.jyn == 0.0) and ec.expelled[0] == 1 and ec.expelled[2] == 0.0


def test_a_particle_where_two_elements_overlap_goes_to_the_nearest_free_foot():
    """Elements that slid over each other overlap (A = [0, 2] x [0, 2] um, B = [1.5, 3.5] x [0, 2]).
    A particle at (1.8, 1.0) is inside both: the nearest foot on A's boundary, (2, 1), lies in B and
    the nearest on B's, (1.5, 1), in A; it goes 1 um, to the top or bottom face, and r_c = 0.5 um in
    front of it, outside both."""
    from solver.sph.coupling import elements_at

    um = 1e-6
    x, y, quads, edges = _two_squares(1.5 * um)
    P = _particle(1.8 * um, 1.0 * um)
    ec = _edge_contact(x, y, np.zeros(8), np.zeros(8), edges, 0.0, 0.5e-6, 10.0, quads)
    found = np.empty(8, np.int64)
    assert elements_at(P.F[pp.X, 0], P.F[pp.Y, 0], quads, x, y, ec.lgrid, ec.lstart, ec.litems, found) == 2
    loop.step_chunk(P, 1, 1e-10, edges=ec)
    assert elements_at(P.F[pp.X, 0], P.F[pp.Y, 0], quads, x, y, ec.lgrid, ec.lstart, ec.litems, found) == 0
    assert P.F[pp.X, 0] == pytest.approx(1.8 * um, rel=1e-9)
    assert min(abs(P.F[pp.Y, 0] + 0.5 * um), abs(P.F[pp.Y, 0] - 2.5 * um)) < 1e-14
    assert ec.expelled[0] == 1 and ec.expelled[1] == pytest.approx(1.0 * um, rel=1e-9) and ec.expelled[3] == 0


def test_a_particle_put_out_of_an_element_across_a_crevice_narrower_than_r_c_goes_a_hair_in_front():
    """Two elements 0.2 um apart (A = [0, 2] x [0, 2] um, B = [2.2, 4.2] x [0, 2]): a particle at (1.9, 1.0),
    inside A, would go r_c = 0.5 um in front of A's right edge, inside B; it goes a hair in front of that
    edge instead, in the crevice, outside both."""
    from solver.sph.coupling import elements_at

    um = 1e-6
    x, y, quads, edges = _two_squares(2.2 * um)
    P = _particle(1.9 * um, 1.0 * um)
    ec = _edge_contact(x, y, np.zeros(8), np.zeros(8), edges, 0.0, 0.5e-6, 10.0, quads)
    loop.step_chunk(P, 1, 1e-10, edges=ec)
    found = np.empty(8, np.int64)
    assert elements_at(P.F[pp.X, 0], P.F[pp.Y, 0], quads, x, y, ec.lgrid, ec.lstart, ec.litems, found) == 0
    assert 2 * um < P.F[pp.X, 0] < 2 * um + 1e-14 and P.F[pp.Y, 0] == pytest.approx(1.0 * um, rel=1e-9)
    assert ec.expelled[0] == 1 and ec.expelled[3] == 0


def _put_out_of_the_square_near_a_tool(x_face, px):
    """One step of a resting particle at (px, 1 um) inside :func:`_square`, the rake face of :func:`_rake_face_tool`
    at x = x_face, no penalty (only the put-out acts): (particles, edge contact, tool)."""
    x, y, quads, edges = _square()
    tool = _rake_face_tool(x_face)
    P = _particle(px, 1e-6)
    ec = _edge_contact(x, y, np.zeros(4), np.zeros(4), edges, 0.0, 0.5e-6, 10.0, quads)
    loop.step_chunk(P, 1, 1e-10, tool=tool, edges=ec)
    return P, ec, tool


def test_a_particle_put_out_of_an_element_towards_the_tool_goes_onto_the_tools_surface():
    """An element 0.2 um from the tool's rake face (rake 0, edge radius 0.5 um, the face at x = 2.2 um
    along the element's right edge): a particle at (1.9, 1.0) um, inside the element, whose place r_c =
    0.5 um in front of that edge is 0.3 um inside the tool, goes onto the tool's surface instead, between
    the tool and the element (inside the tool, the tool's penalty would fling it out)."""
    from solver.tool import tool_sdf

    um = 1e-6
    P, ec, tool = _put_out_of_the_square_near_a_tool(2.2e-6, 1.9e-6)
    assert tool_sdf(2.5 * um, 1.0 * um, tool)[0] == pytest.approx(-0.3 * um, rel=1e-9)
    assert P.F[pp.X, 0] == pytest.approx(2.2 * um, rel=1e-9) and P.F[pp.Y, 0] == pytest.approx(1.0 * um, rel=1e-9)
    assert ec.expelled[0] == 1


def test_a_particle_in_an_element_that_overlaps_the_tool_goes_to_a_free_place_outside_both():
    """An element that overlaps the tool (A = [0, 2] x [0, 2] um, the rake face at x = 1.8 um, so A's right
    edge is 0.2 um inside the tool, as the tool's penalty lets nodes sink in): a particle at (1.7, 1.0) um,
    inside A, is nearest to the right edge, but every place in front of it (r_c or a hair) is inside the tool,
    and the tool's surface there is inside A. It goes to the nearest place outside both, r_c in front of A's
    top edge, not 0.2 um into the tool, from where the tool's penalty would fling it out."""
    from solver.sph.coupling import elements_at
    from solver.tool import tool_sdf

    um = 1e-6
    P, ec, tool = _put_out_of_the_square_near_a_tool(1.8e-6, 1.7e-6)
    x, y, quads, _ = _square()
    assert tool_sdf(2.0 * um, 1.0 * um, tool)[0] == pytest.approx(-0.2 * um, rel=1e-9)
    found = np.empty(8, np.int64)
    assert tool_sdf(P.F[pp.X, 0], P.F[pp.Y, 0], tool)[0] >= 0.0
    assert elements_at(P.F[pp.X, 0], P.F[pp.Y, 0], quads, x, y, ec.lgrid, ec.lstart, ec.litems, found) == 0
    assert P.F[pp.X, 0] == pytest.approx(1.7 * um, rel=1e-9) and P.F[pp.Y, 0] == pytest.approx(2.5 * um, rel=1e-9)
    assert ec.expelled[0] == 1 and ec.expelled[3] == 0


def test_a_plastic_impact_on_an_edge_of_nodes_as_heavy_as_the_particle_shares_the_impulse():
    """The same particle put back on the bottom edge, now of nodes with the particle's mass: the plastic
    impact is a two-body one, with the reduced mass mu = 1 / (1/m + (1-s)^2/M_a + s^2/M_b) = m / 1.5 at
    s = 1/2. The particle keeps (1 - mu/m) of its normal velocity, the nodes take the impulse J = mu v_n
    (momentum whole), and once they have it the particle and the edge point move together along the
    normal; the energy lost, booked, is (1/2) mu v_n^2 (an earlier version cancelled the particle's v_n
    as against a rigid wall and (1/2) m v_n^2 booked: the light edge then took off, energy made)."""
    L = 2e-6
    x, y = np.array([0.0, L, L, 0.0]), np.array([0.0, 0.0, L, L])
    quads = np.array([[0, 1, 2, 3]], np.int32)
    edges = np.array([[0, 1, 0], [1, 2, 0], [2, 3, 0], [3, 0, 0]], np.int32)
    P = _particle(1e-6, 0.4e-6)
    P.F[pp.VX, 0], P.F[pp.VY, 0] = 1.0, 2.0
    m = float(P.F[pp.M, 0])
    ec = _edge_contact(x, y, np.zeros(4), np.zeros(4), edges, 0.0, 0.5e-6, 10.0, quads)
    ec.nmass = np.full(4, m)
    assert loop.step_chunk(P, 1, 1e-10, edges=ec).status == "ok"
    s = P.F[pp.X, 0] / L
    mu = 1.0 / (1.0 / m + (1 - s) ** 2 / m + s**2 / m)
    assert mu == pytest.approx(m / 1.5, rel=1e-3)
    assert P.F[pp.VY, 0] == pytest.approx(2.0 * (1 - mu / m), rel=1e-9) and P.F[pp.VX, 0] == pytest.approx(1.0)
    jy = ec.jyn.sum()  # the nodes' impulse (along -y: into the body, away from the particle)
    assert jy == pytest.approx(2.0 * mu, rel=1e-9) and m * (P.F[pp.VY, 0] - 2.0) == pytest.approx(-jy, rel=1e-9)
    # the nodes move off with the impulse: the edge point's velocity is the particle's normal one now
    v_edge = (1 - s) * ec.jyn[0] / m + s * ec.jyn[1] / m
    assert v_edge == pytest.approx(P.F[pp.VY, 0], rel=1e-9)
    ke_nodes = 0.5 * (ec.jyn[0] ** 2 + ec.jyn[1] ** 2) / m
    assert ec.expelled[5] == pytest.approx(0.5 * mu * 2.0**2, rel=1e-9)  # the loss booked
    assert ec.expelled[2] + ke_nodes == pytest.approx(-ec.expelled[5], rel=1e-9)  # = what particle and nodes lost


def test_a_particle_pressed_on_a_surface_of_several_edges_keeps_its_load_from_edge_to_edge():
    """A particle pressed up by a constant force onto a surface of five 1-um edges (the body above) and
    sliding along it at 5 m/s: each edge it reaches starts its contact with the compression the particle
    carried, so the surface holds it as one surface and it sinks no deeper at the fourth junction than on
    the first edge. (Were each new pair to start unstrained, the particle would sink by another f / k at
    every junction.)"""
    n = 6
    x, y = np.linspace(0.0, 5e-6, n), np.zeros(n)
    edges = np.array([[j, j + 1, 0] for j in range(n - 1)], np.int32)  # outward normal down
    r_c, dt = 0.5e-6, 1e-10
    P = _particle(0.3e-6, -r_c + 1e-9)
    m = float(P.F[pp.M, 0])
    k = 0.1 * m / dt**2
    P.F[pp.VX, 0] = 5.0
    P.F[pp.FYE, 0] = k * 20e-9  # equilibrium compression 20 nm
    P.forces_valid = False
    ec = _edge_contact(x, y, np.zeros(n), np.zeros(n), edges, k, r_c, 1e3)  # the limit does not act
    depth = []  # the overlap r_c - g = r_c + y, and the edge the particle is over
    for _ in range(900):
        assert loop.step_chunk(P, 10, dt, edges=ec).status == "ok"
        depth.append((r_c + P.F[pp.Y, 0], int(P.F[pp.X, 0] // 1e-6)))
    d = np.array(depth)
    assert d[-1, 1] == 4  # it crossed four junctions
    first = d[d[:, 1] == 0, 0].max()
    assert 20e-9 < first < 60e-9  # oscillating about the equilibrium, from its entry
    assert d[:, 0].max() < first + 5e-9


def test_an_edge_that_comes_within_reach_of_a_resting_particle_does_not_push_it():
    """A particle resting on a horizontal edge (its pair unstrained) when a second edge appears beside it,
    0.3 um away (an element's death exposes it, or the particle sits in a concave corner): the new pair
    starts with the particle's carried compression, none, so the particle stays at rest; it is not pushed
    by an overlap no motion of its own made (in an earlier version the particle's one offset let the new face
    push with 0.3 um less its overlap with the first)."""
    x, y = np.array([0.0, 4e-6, 2.3e-6, 2.3e-6]), np.array([0.0, 0.0, -2e-6, 0.0])
    r_c, dt = 0.5e-6, 1e-10
    P = _particle(2e-6, -0.2e-6)  # 0.3 um overlap with the horizontal edge, its contact started there
    k = 0.1 * float(P.F[pp.M, 0]) / dt**2
    one = np.array([[0, 1, 0]], np.int32)
    ec = _edge_contact(x, y, np.zeros(4), np.zeros(4), one, k, r_c, 10.0)
    assert loop.step_chunk(P, 20, dt, edges=ec).status == "ok" and P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    # the vertical edge from (2.3, 0) down to (2.3, -2) um: outward normal (dy, -dx) / L = (-1, 0), towards the
    # particle 0.3 um to its left
    two = np.array([[0, 1, 0], [3, 2, 0]], np.int32)
    ec = _edge_contact(x, y, np.zeros(4), np.zeros(4), two, k, r_c, 10.0)
    assert loop.step_chunk(P, 50, dt, edges=ec).status == "ok"
    assert P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    pairs = P.scratch["edge_pairs"]
    assert np.count_nonzero(pairs[1::4, 0]) == 2  # both pairs remembered, neither compressed
    assert np.all(pairs[3::4, 0] == 0.0)


def test_a_particle_pressed_on_an_edge_harder_than_the_separation_limit_holds_it_stays_out_and_passes_the_load_on():
    """A particle pressed up onto a fixed edge (the body above) by a constant force 100 m v_sep / dt,
    what the separation-speed limit alone would let the edge push back with in a step: the limit adds what
    the other forces press into the edge, so the particle comes to rest in front of the edge, at the
    spring's equilibrium compression f / k, and the nodes take the force. (It first overshoots to 2 f / k;
    the limit lets it back out at v_sep, over f / k / v_sep = 1000 steps.) Bounded by m v_sep / dt alone,
    the edge held it back with a hundredth of the force and it was pushed through the edge's line."""
    L, r_c, dt = 4e-6, 0.5e-6, 1e-10
    x, y = np.array([0.0, L]), np.array([0.0, 0.0])
    edges = np.array([[0, 1, 0]], np.int32)  # outward normal (0, -1)
    v_sep = 1.0
    P = _particle(0.5 * L, -r_c + 1e-9)  # just within reach, at rest
    m = float(P.F[pp.M, 0])
    k = 0.1 * m / dt**2
    f = 100.0 * m * v_sep / dt
    P.F[pp.FYE, 0] = f
    P.forces_valid = False
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), edges, k, r_c, v_sep)
    gaps, reactions = [], []
    for _ in range(3000):
        assert loop.step_chunk(P, 1, dt, edges=ec).status == "ok"
        gaps.append(-P.F[pp.Y, 0])
        reactions.append(ec.fyn.sum())
    gaps = np.array(gaps)
    assert gaps.min() > 0.0  # never behind the edge's line
    compression = r_c - gaps[-1000:] - 1e-9  # the overlap beyond the one its pair started from
    assert np.mean(compression) == pytest.approx(f / k, rel=0.05)  # at rest on the spring
    assert r_c - gaps.min() - 1e-9 < 2.05 * f / k  # it overshoots to 2 f / k, no deeper
    assert np.mean(reactions[-1000:]) == pytest.approx(f, rel=0.05)  # the nodes take the load
