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
    head, nxt = np.empty(ncx * ncy, np.int64), np.empty(edges.shape[0], np.int64)
    _build_cells(x, y, edges, x0, y0, cell, ncx, ncy, head, nxt)
    live = np.arange(quads.shape[0], dtype=np.int64)
    lstart, litems, lgrid = bin_elements(quads, live, x, y, 0.5e-6, x0, y0, x0 + ncx * cell, y0 + ncy * cell)
    return loop.EdgeContact(edges, quads, x, y, vx, vy, np.array([x0, y0, cell, ncx, ncy, k, r_c, v_sep, 0.0]), head, nxt,
                            lgrid, lstart, litems)


def _particle(px, py, dp=1e-6):
    mats = mt.table(mt.isotropic(3e9, 0.3, 1200.0))
    return pp.from_points([px], [py], mats, pp.make_params(dp))


def test_a_particle_put_on_an_edge_leaves_no_faster_than_the_separation_speed():
    """A particle on a 4 um edge (a hair in front of it; the body is above the edge, its outward normal
    points down), as the projection out of an element leaves it: the penalty spring holds k r_c, by no
    motion of the particle's. It is pushed out along the normal no faster than v_sep, and the nodes take
    the opposite impulse (momentum conserved)."""
    L, r_c, v_sep = 4e-6, 0.5e-6, 10.0
    x, y = np.array([0.0, L]), np.array([0.0, 0.0])
    edges = np.array([[0, 1, 0]], np.int32)  # a -> b along +x: outward normal (dy, -dx) / L = (0, -1)
    P = _particle(0.5 * L, -1e-12)
    m = float(P.F[pp.M, 0])
    dt = 1e-10
    k = 1e3 * m / dt**2  # far too stiff without the speed limit: one step would launch it
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), edges, k, r_c, v_sep)
    speeds = []
    jy = 0.0
    for _ in range(40):
        rep = loop.step_chunk(P, 60, dt, edges=ec)
        assert rep.status == "ok"
        jy += ec.fyn.sum() * dt  # the reaction forces summed over the steps
        speeds.append(float(np.hypot(P.F[pp.VX, 0], P.F[pp.VY, 0])))
    assert P.F[pp.Y, 0] < -r_c * 0.99  # it came out below the edge, to the contact radius
    assert max(speeds) <= v_sep * (1 + 1e-9)
    assert P.F[pp.VY, 0] < 0 and abs(P.F[pp.VX, 0]) < 1e-12
    assert m * P.F[pp.VY, 0] == pytest.approx(-jy, rel=1e-9)  # the nodes' impulse balances the particle's
    assert ec.out[0] == pytest.approx(r_c, rel=1e-5)  # r_c less the hair (1e-12 m)


def test_a_particle_behind_an_edge_but_in_no_element_feels_nothing_from_it():
    """Behind an edge's line (0.3 um, within its span) but inside no living element: past a corner of
    the body or across a thin piece, not this edge's business. Until session 14 an edge pushed particles
    up to half its length behind it, sideways past a corner."""
    x, y = np.array([0.0, 4e-6]), np.array([0.0, 0.0])
    P = _particle(2e-6, 0.3e-6)  # above the edge, on the body's side of it; NO_ELEMENT: in no element
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), np.array([[0, 1, 0]], np.int32), 1e12, 0.5e-6, 10.0)
    rep = loop.step_chunk(P, 20, 1e-10, edges=ec)
    assert rep.status == "ok" and P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    assert np.all(ec.fxn == 0) and np.all(ec.fyn == 0) and ec.out[1] == 0


def test_a_converted_particle_is_not_pushed_by_the_overlap_it_was_born_with():
    """A particle converted 0.2 um in front of an edge (r_c = 0.5 um: its spring 0.3 um compressed by no
    motion of its own) starts its contact unstrained (edge offset d0 = 0.3 um): at rest it stays at rest,
    where the spring alone would launch it. Moved 0.1 um further in, the spring pushes it back out with
    no more kinetic energy than those 0.1 um store, k (0.1 um)^2 / 2."""
    x, y = np.array([0.0, 4e-6]), np.array([0.0, 0.0])  # the body above, the outward normal down
    P = _particle(2e-6, -0.2e-6)
    P.F[pp.DOFF, 0] = np.inf  # as conversion leaves it
    k = 0.1 * float(P.F[pp.M, 0]) / 1e-10**2
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), np.array([[0, 1, 0]], np.int32), k, 0.5e-6, 10.0)
    rep = loop.step_chunk(P, 50, 1e-10, edges=ec)
    assert rep.status == "ok" and P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    assert P.F[pp.DOFF, 0] == pytest.approx(0.3e-6, rel=1e-9)
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


def test_a_particle_inside_an_element_is_put_on_its_nearest_edge_and_stops_going_in():
    """The kinematic condition (expel_from_elements): a particle 0.4 um inside a 2 um square element
    whose four edges are exposed, moving at (1, 2) m/s (into the element through its bottom edge), is
    put on the bottom edge after one step, its normal velocity relative to the resting edge cancelled
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
    assert P.F[pp.Y, 0] <= 0.0 and P.F[pp.Y, 0] > -1e-14  # on the bottom edge, a hair outside
    assert P.F[pp.X, 0] == pytest.approx(1e-6 + 1e-10, rel=1e-9)  # the drift along the edge, kept
    assert P.F[pp.VX, 0] == pytest.approx(1.0, rel=1e-12) and abs(P.F[pp.VY, 0]) < 1e-12
    # momentum: the nodes' impulse balances the particle's change (m dv = -2 m in y)
    assert ec.jyn.sum() == pytest.approx(2.0 * m, rel=1e-9) and abs(ec.jxn.sum()) < 1e-12 * m
    assert ec.jyn[0] == pytest.approx(ec.jyn[1], rel=1e-6)  # the foot is at the edge's middle
    assert ec.expelled[0] == 1 and ec.expelled[1] == pytest.approx(0.4e-6 + 2e-10, rel=1e-6)
    assert ec.expelled[2] == pytest.approx(0.5 * m * (1.0 - 5.0), rel=1e-9)


def test_a_particle_leaving_an_element_keeps_its_velocity():
    """Inside but already moving out through its nearest edge: put on the edge, velocity unchanged
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
    the nearest on B's, (1.5, 1), in A; it goes 1 um, to the top or bottom face, outside both."""
    from solver.sph.coupling import elements_at

    um = 1e-6
    x = np.array([0.0, 2, 2, 0, 1.5, 3.5, 3.5, 1.5]) * um
    y = np.array([0.0, 0, 2, 2, 0, 0, 2, 2]) * um
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]], np.int32)
    edges = np.array([[0, 1, 0], [1, 2, 0], [2, 3, 0], [3, 0, 0], [4, 5, 1], [5, 6, 1], [6, 7, 1], [7, 4, 1]], np.int32)
    P = _particle(1.8 * um, 1.0 * um)
    ec = _edge_contact(x, y, np.zeros(8), np.zeros(8), edges, 0.0, 0.5e-6, 10.0, quads)
    found = np.empty(8, np.int64)
    assert elements_at(P.F[pp.X, 0], P.F[pp.Y, 0], quads, x, y, ec.lgrid, ec.lstart, ec.litems, found) == 2
    loop.step_chunk(P, 1, 1e-10, edges=ec)
    assert elements_at(P.F[pp.X, 0], P.F[pp.Y, 0], quads, x, y, ec.lgrid, ec.lstart, ec.litems, found) == 0
    assert P.F[pp.X, 0] == pytest.approx(1.8 * um, rel=1e-9)
    assert min(abs(P.F[pp.Y, 0]), abs(P.F[pp.Y, 0] - 2 * um)) < 1e-14
    assert ec.expelled[0] == 1 and ec.expelled[1] == pytest.approx(1.0 * um, rel=1e-9) and ec.expelled[3] == 0
