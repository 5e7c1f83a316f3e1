"""Particle - element-edge coupling (solver.sph.coupling) inside the compiled SPH step."""

import numpy as np
import pytest

from solver.contact import _build_cells
from solver.sph import loop, materials as mt, particles as pp


def _edge_contact(x, y, vx, vy, edges, k, r_c, v_sep):
    cell = float(np.max(np.hypot(x[edges[:, 1]] - x[edges[:, 0]], y[edges[:, 1]] - y[edges[:, 0]]))) + r_c
    x0, y0 = float(x.min()) - cell, float(y.min()) - cell
    ncx, ncy = int((x.max() - x0) / cell) + 2, int((y.max() - y0) / cell) + 2
    head, nxt = np.empty(ncx * ncy, np.int64), np.empty(edges.shape[0], np.int64)
    _build_cells(x, y, edges, x0, y0, cell, ncx, ncy, head, nxt)
    return loop.EdgeContact(edges, x, y, vx, vy, np.array([x0, y0, cell, ncx, ncy, k, r_c, v_sep]), head, nxt)


def _particle(px, py, dp=1e-6):
    mats = mt.table(mt.isotropic(3e9, 0.3, 1200.0))
    return pp.from_points([px], [py], mats, pp.make_params(dp))


def test_a_particle_deep_behind_an_edge_leaves_no_faster_than_the_separation_speed():
    """A particle 1.5 um behind a 4 um edge (the body is above the edge, its outward normal points
    down) is pushed out along the normal; its speed never exceeds v_sep although the penalty spring
    holds k (r_c + 1.5 um), and the nodes take the opposite impulse (momentum conserved)."""
    L, r_c, v_sep = 4e-6, 0.5e-6, 10.0
    x, y = np.array([0.0, L]), np.array([0.0, 0.0])
    edges = np.array([[0, 1, 0]], np.int32)  # a -> b along +x: outward normal (dy, -dx) / L = (0, -1)
    P = _particle(0.5 * L, 1.5e-6)
    m = float(P.F[pp.M, 0])
    dt = 1e-10
    k = 1e3 * m / dt**2  # far too stiff without the speed limit: one step would launch it
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), edges, k, r_c, v_sep)
    speeds = []
    jy = 0.0
    for _ in range(40):
        rep = loop.step_chunk(P, 60, dt, edges=ec)
        assert rep.status == "ok"
        jy += ec.fyn.sum()
        speeds.append(float(np.hypot(P.F[pp.VX, 0], P.F[pp.VY, 0])))
    assert P.F[pp.Y, 0] < -r_c * 0.99  # it came out below the edge, to the contact radius
    assert max(speeds) <= v_sep * (1 + 1e-9)
    assert P.F[pp.VY, 0] < 0 and abs(P.F[pp.VX, 0]) < 1e-12
    assert m * P.F[pp.VY, 0] == pytest.approx(-jy, rel=1e-9)  # the nodes' impulse balances the particle's
    assert ec.out[0] == pytest.approx(r_c + 1.5e-6, rel=0.05)


def test_a_particle_clear_of_the_edges_feels_nothing():
    x, y = np.array([0.0, 4e-6]), np.array([0.0, 0.0])
    P = _particle(2e-6, -2e-6)  # 2 um outside (below) the edge, beyond r_c
    ec = _edge_contact(x, y, np.zeros(2), np.zeros(2), np.array([[0, 1, 0]], np.int32), 1e12, 0.5e-6, 10.0)
    rep = loop.step_chunk(P, 20, 1e-10, edges=ec)
    assert rep.status == "ok" and P.F[pp.VX, 0] == 0.0 and P.F[pp.VY, 0] == 0.0
    assert np.all(ec.fxn == 0) and np.all(ec.fyn == 0) and ec.out[1] == 0
