"""Particles put back out of living hexahedra (:func:`solver.hybrid.faces3d.expel_from_hexes`), and the
particle-face springs' pair memory (:func:`solver.hybrid.faces3d.particle_faces`).

A block of unit hexahedra, one particle inside an element just under the top face moving into the block:
it goes to the point the springs' rest distance r_c in front of the nearest face point, its velocity
relative to that face's triangle along the normal is cancelled by a plastic impact whose impulse the
triangle's nodes take as one body (momentum kept to round-off, the energy lost is (1/2) mu v_n^2 with the
reduced mass), its tangential velocity is kept, and its remembered springs' energy is booked and forgotten. A particle outside is left
alone; one with no boundary face in reach stays where it is and is counted. A face point whose place in front
lies inside the tool is not free: the particle goes to the nearest one outside it.
"""

import numpy as np
import pytest

from solver.fem3d.contact3d import boundary_faces
from solver.fem3d.gridmesh3d import box_mesh
from solver.hybrid.faces3d import (NPAIR, PAIR_ROWS, expel_from_hexes, face_key, grid_for, inside_living,
                                   new_pair_memory, particle_faces)

UM = 1e-6
R_C = 0.3 * UM
D_MAX = 0.5 * UM
K = 2.0  # the pair springs' stiffness [N/m]: only their energy is checked


def _expel(mesh, px, pv, pm, vn, invm, reach, z_range=(-np.inf, np.inf), tool=np.zeros(0), pairs=None):
    hexes = np.ascontiguousarray(mesh.hexes, dtype=np.int64)
    faces = np.ascontiguousarray(boundary_faces(hexes)[:, :4])
    grid = grid_for(px, 1.0 * UM, 2.0 * UM)
    jn = np.zeros_like(vn)
    out = np.zeros(7)
    if pairs is None:
        pairs = new_pair_memory(px.shape[1])
    expel_from_hexes(px, pv, pm, mesh.X, vn, invm, hexes, faces, grid, reach, K, R_C, 1e-9 * UM, tool, *z_range,
                     pairs, jn, out)
    return jn, out, grid


def _remember(pairs, p, key, d0, c):
    """Particle p remembers one pair (slot 0) with the face ``key``, offset d0 and compression c."""
    pairs[1:4, p] = key, d0, c
    pairs[0, p] = c


def test_a_particle_under_the_top_face_goes_out_with_a_plastic_impact_on_it():
    mesh = box_mesh(3, 3, 2, 3 * UM, 3 * UM, 2 * UM)  # the top face at z = 2 um
    px = np.array([[1.4, 2.5], [1.7, 1.5], [1.8, 4.0]]) * UM  # the first 0.2 um under the top, the second above
    v0 = np.array([[0.3, 0.1], [-0.2, 0.0], [-2.0, -1.0]])  # m/s, the first going in
    pv = v0.copy()
    pm = np.array([3e-13, 3e-13])
    rng = np.random.default_rng(1)
    vn = np.ascontiguousarray(rng.uniform(-0.2, 0.2, mesh.X.shape) + np.array([[0.0], [0.0], [0.5]]))
    m_node = rng.uniform(0.5e-12, 2e-12, mesh.X.shape[1])
    invm = 1.0 / m_node
    pairs = new_pair_memory(2)
    c0, c1 = 0.4 * UM, 0.1 * UM  # the first's spring against the top face, the second's against another
    _remember(pairs, 0, 7.0, 0.1 * UM, c0)
    _remember(pairs, 1, 9.0, 0.0, c1)
    kept = pairs[:, 1].copy()
    jn, out, grid = _expel(mesh, px, pv, pm, vn, invm, reach=1.0 * UM, pairs=pairs)

    assert out[0] == 1 and out[3] == 0 and out[4] == 0
    # in front of the nearest face point (straight above, on the top face), at the springs' rest distance
    assert px[:, 0] == pytest.approx(np.array([1.4 * UM, 1.7 * UM, 2 * UM + R_C]), abs=1e-12 * UM)
    assert out[1] == pytest.approx(0.2 * UM + R_C, rel=1e-9)
    assert np.array_equal(px[:, 1], np.array([2.5, 1.5, 4.0]) * UM) and np.array_equal(pv[:, 1], v0[:, 1])
    # momentum: the particle's change and the nodes' impulses cancel
    dp = pm[0] * (pv[:, 0] - v0[:, 0])
    assert np.abs(dp + jn.sum(axis=1)).max() < 1e-12 * np.abs(dp).max()
    # along the face only the normal velocity changed
    assert pv[0, 0] == pytest.approx(v0[0, 0], rel=1e-12) and pv[1, 0] == pytest.approx(v0[1, 0], rel=1e-12)
    # the face's triangle under the particle takes the impulse, its three nodes as one body: shares by mass,
    # the same velocity change for each, after which particle and triangle no longer approach
    hit = np.flatnonzero(np.abs(jn).sum(axis=0))
    assert hit.size == 3 and np.allclose(mesh.X[2, hit], 2 * UM)
    xy = mesh.X[:2, hit]
    assert xy.min(axis=1) == pytest.approx([1 * UM, 1 * UM]) and xy.max(axis=1) == pytest.approx([2 * UM, 2 * UM])
    dv = invm[hit] * jn[:, hit]
    assert np.allclose(dv, dv[:, :1], rtol=1e-12, atol=0)
    m_t = float(m_node[hit].sum())
    v_t = vn[:, hit] @ m_node[hit] / m_t
    assert pv[2, 0] == pytest.approx(float(v_t[2] + dv[2, 0]), rel=1e-12)
    # energy: what particle and nodes lost together is the plastic impact's (1/2) mu v_n^2
    v_n = v0[2, 0] - float(v_t[2])
    mu = 1.0 / (1.0 / pm[0] + 1.0 / m_t)
    assert out[5] == pytest.approx(0.5 * mu * v_n ** 2, rel=1e-12)
    v_after = vn[:, hit] + dv
    dke_p = 0.5 * pm[0] * (np.sum(pv[:, 0] ** 2) - np.sum(v0[:, 0] ** 2))
    dke_n = float(np.sum(0.5 * m_node[hit] * (np.sum(v_after ** 2, axis=0) - np.sum(vn[:, hit] ** 2, axis=0))))
    assert out[2] == pytest.approx(dke_p, rel=1e-12)
    assert dke_p + dke_n == pytest.approx(-out[5], rel=1e-9)
    # the springs: the moved particle's remembered pairs are forgotten with their energy; the other's kept
    assert out[6] == pytest.approx(0.5 * K * c0 ** 2, rel=1e-12)
    assert not pairs[:, 0].any() and np.array_equal(pairs[:, 1], kept)
    assert inside_living(px, mesh.X, np.ascontiguousarray(mesh.hexes, dtype=np.int64), grid, 1e-9 * UM,
                         np.zeros(2)) == 0


def test_a_particle_leaving_the_face_faster_than_it_keeps_its_velocity():
    """A particle inside but already moving out faster than the face: moved, no impact, no loss."""
    mesh = box_mesh(2, 2, 1, 2 * UM, 2 * UM, 1 * UM)
    px = np.array([[0.6], [0.7], [0.9]]) * UM
    pv = np.array([[0.0], [0.0], [3.0]])
    vn = np.zeros_like(mesh.X)
    jn, out, _ = _expel(mesh, px, pv, np.array([1e-13]), vn, np.full(mesh.X.shape[1], 1e12), reach=1.0 * UM)
    assert out[0] == 1 and out[5] == 0 and not jn.any()
    assert pv[2, 0] == 3.0 and px[2, 0] == pytest.approx(1 * UM + R_C, rel=1e-12)


def test_a_particle_with_no_face_in_reach_stays_and_is_counted():
    mesh = box_mesh(5, 5, 5, 5 * UM, 5 * UM, 5 * UM)
    px = np.array([[2.5], [2.5], [2.5]]) * UM  # 2.5 um from every boundary face
    before = px.copy()
    pv = np.array([[0.0], [0.0], [-1.0]])
    jn, out, _ = _expel(mesh, px, pv, np.array([1e-13]), np.zeros_like(mesh.X), np.ones(mesh.X.shape[1]),
                        reach=1.0 * UM)
    assert out[0] == 0 and out[4] == 1
    assert np.array_equal(px, before) and pv[2, 0] == -1.0 and not jn.any()


def test_impacts_see_a_node_on_a_symmetry_side_with_its_mass_and_a_clamped_node_as_rigid():
    """The coupler's nodal 1 / M for the impacts: a node fixed only normal to the strip's side moves in the
    plane of the faces the particles meet there, so it keeps its mass; a node fixed in every direction does
    not move (0)."""
    from solver.fem3d import loop as floop, material3d
    from solver.hybrid.coupler3d import Hybrid3dCoupler
    from solver.sph import materials as mt
    from solver.sph3d import particles as pp

    mesh = box_mesh(2, 2, 2, 2 * UM, 2 * UM, 2 * UM)
    s = floop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(3e9, 0.4)], [1280.0])
    side = np.flatnonzero(np.isclose(s.X0[2], 0.0))
    s.fix[2, side] = 1
    clamped = side[:2]
    s.fix[:, clamped] = 1
    c = Hybrid3dCoupler(s, mt.table(mt.isotropic(3e9, 0.4, 1280.0)), np.array([True]), pp.make_params(1 * UM), 1.0, R_C)
    c._node_masses(s)
    free_side = np.setdiff1d(side, clamped)
    assert np.allclose(c.invm[free_side], 1.0 / s.meff[free_side], rtol=1e-14)
    assert np.all(c.invm[clamped] == 0.0)


def test_a_particle_is_not_put_beyond_the_strips_side():
    """The strip's side at z = 1 um is a wall for the particles: a particle put out through a face there
    stays on the wall's plane, not r_c beyond it."""
    mesh = box_mesh(2, 2, 1, 2 * UM, 2 * UM, 1 * UM)
    px = np.array([[0.6], [0.7], [0.9]]) * UM
    pv = np.array([[0.0], [0.0], [0.5]])
    _, out, _ = _expel(mesh, px, pv, np.array([1e-13]), np.zeros_like(mesh.X), np.ones(mesh.X.shape[1]),
                       reach=1.0 * UM, z_range=(0.0, 1.0 * UM))
    assert out[0] == 1 and px[2, 0] == pytest.approx(1.0 * UM, rel=1e-12)


def test_a_particle_is_not_put_inside_the_tool():
    """The nearest face point's place in front (r_c over the top face y = 3 um, 0.2 um above the particle)
    lies inside the tool (a wedge of rake 0 and clearance 7 deg with its lowest point at (2, 3.1) um,
    extruded along z): the particle goes onto the tool's surface along its normal, between the tool and the
    face, and the spring it finds compressed there is booked with the move; with no tool it goes r_c over
    the top face."""
    from solver.tool import tool_sdf

    g = np.radians(7.0)
    # solver.tool.tool_array's layout: edge centre x, y, velocity, radius, ..., cos/sin rake, cos/sin clearance, mirror
    tool = np.array([2.0 * UM, 3.1 * UM, 0.0, 0.0, 1e-12, 0.0, 0.0, 1.0, 0.0, np.cos(g), np.sin(g), 1.0])
    mesh = box_mesh(3, 3, 2, 3 * UM, 3 * UM, 2 * UM)
    start = np.array([[2.5], [2.8], [1.3]]) * UM
    place = np.array([2.5 * UM, 3.0 * UM + R_C, 1.3 * UM])
    sd, snx, sny = tool_sdf(place[0], place[1], tool)
    assert sd < 0.0  # r_c over the top face: inside the tool
    on_tool = place - sd * np.array([snx, sny, 0.0])
    for t, where in ((np.zeros(0), place), (tool, on_tool)):
        px = start.copy()
        _, out, _ = _expel(mesh, px, np.zeros((3, 1)), np.array([1e-13]), np.zeros_like(mesh.X),
                           np.ones(mesh.X.shape[1]), reach=1.0 * UM, tool=t)
        assert out[0] == 1 and out[3] == 0
        assert px[:, 0] == pytest.approx(where, abs=1e-12 * UM)
        gap = px[1, 0] - 3.0 * UM
        assert 0.0 < gap <= R_C * (1 + 1e-9)
    assert abs(tool_sdf(px[0, 0], px[1, 0], tool)[0]) < 1e-9 * UM and gap < R_C


# ---------------------------------------------------------------------------------------------- pair memory
def _block_faces():
    """One unit hexahedron (1 um): its six faces, and the top face (z = 1 um)'s row and key."""
    mesh = box_mesh(1, 1, 1, 1 * UM, 1 * UM, 1 * UM)
    faces = np.ascontiguousarray(boundary_faces(np.ascontiguousarray(mesh.hexes, dtype=np.int64))[:, :4])
    top = int(np.flatnonzero(np.all(np.isclose(mesh.X[2, faces], 1 * UM), axis=1))[0])
    return mesh, faces, top, face_key(faces, top)


def _faces_step(mesh, faces, px, pv, pairs, dt, vn=None):
    fp = np.zeros_like(px)
    fn = np.zeros_like(mesh.X)
    out = np.zeros(5)
    vn = np.zeros_like(mesh.X) if vn is None else vn
    particle_faces(px, pv, mesh.X, vn, faces, grid_for(px, 1.0 * UM, 2.0 * UM), K, R_C, D_MAX, dt, pairs, fp, fn, out)
    return fp, fn, out


def test_a_particle_born_within_reach_of_a_face_is_not_pushed_by_an_overlap_it_did_not_make():
    """At rest 0.1 um over the top face (overlap r_c - 0.1 um): its new pair starts unstrained, no force, no
    energy; moved 0.05 um closer, the spring holds exactly that compression; moved back past where it
    started, the offset follows it (c = 0, no pull)."""
    mesh, faces, top, key = _block_faces()
    px = np.array([[0.5], [0.5], [1.1]]) * UM
    pv = np.zeros((3, 1))
    pairs = new_pair_memory(1)
    fp, fn, out = _faces_step(mesh, faces, px, pv, pairs, dt=1e-9)
    assert not fp.any() and not fn.any() and out[0] == 0.0 and out[4] == 0.0
    assert pairs[1, 0] == key and pairs[2, 0] == pytest.approx(R_C - 0.1 * UM, rel=1e-12)
    px[2, 0] -= 0.05 * UM
    fp, fn, out = _faces_step(mesh, faces, px, pv, pairs, dt=1e-9)
    assert fp[2, 0] == pytest.approx(K * 0.05 * UM, rel=1e-9) and fp[:2, 0] == pytest.approx([0.0, 0.0], abs=1e-30)
    assert np.abs(fp.sum(axis=1) + fn.sum(axis=1)).max() < 1e-15 * fp[2, 0]  # action = reaction
    assert out[0] == pytest.approx(0.5 * K * (0.05 * UM) ** 2, rel=1e-9) and out[4] == 0.0
    px[2, 0] += 0.15 * UM  # 0.2 um over the face: still in reach, farther than the offset
    fp, _, out = _faces_step(mesh, faces, px, pv, pairs, dt=1e-9)
    assert not fp.any() and out[0] == 0.0 and pairs[2, 0] == pytest.approx(R_C - 0.2 * UM, rel=1e-12)


def test_a_new_pair_is_compressed_by_the_approach_of_its_step_and_by_the_carried_compression():
    """Approaching at 10 m/s over dt = 1e-9 s (10 nm), the new pair starts 10 nm compressed (the step's
    work pays it); with a carried compression of 20 nm on top it starts at 30 nm, and the carried part's
    energy is booked as made (out[4] < 0)."""
    mesh, faces, top, key = _block_faces()
    px = np.array([[0.5], [0.5], [1.1]]) * UM
    pv = np.array([[0.0], [0.0], [-10.0]])
    pairs = new_pair_memory(1)
    fp, _, out = _faces_step(mesh, faces, px, pv, pairs, dt=1e-9)
    assert fp[2, 0] == pytest.approx(K * 1e-8, rel=1e-9) and out[4] == 0.0
    pairs = new_pair_memory(1)
    pairs[0, 0] = 2e-8  # carried from the last step (a pair with another face that has gone)
    fp, _, out = _faces_step(mesh, faces, px, pv, pairs, dt=1e-9)
    assert fp[2, 0] == pytest.approx(K * 3e-8, rel=1e-9)
    assert out[4] == pytest.approx(-0.5 * K * 2e-8 ** 2, rel=1e-9)


def test_a_forgotten_pair_books_its_springs_energy():
    """A remembered pair whose face is gone (its element died: no face left) is forgotten and its energy
    k c^2 / 2 is booked; a slot per face, at most NPAIR."""
    mesh, faces, top, key = _block_faces()
    px = np.array([[0.5], [0.5], [1.1]]) * UM
    pairs = new_pair_memory(1)
    _remember(pairs, 0, key, 0.0, 0.05 * UM)
    _, _, out = _faces_step(mesh, faces[:0], px, np.zeros((3, 1)), pairs, dt=1e-9)
    assert out[4] == pytest.approx(0.5 * K * (0.05 * UM) ** 2, rel=1e-12) and not pairs.any()
    assert PAIR_ROWS == 1 + 3 * NPAIR


def test_a_particle_bouncing_off_a_face_keeps_its_energy():
    """A particle flying at a fixed face, integrated by the leapfrog with the springs' force: it comes back
    at the speed it came in (the spring conservative, its energy a state of the memory, nothing booked),
    to the integration's error."""
    mesh, faces, top, key = _block_faces()
    m = 1e-15
    v0 = 5.0
    k = K
    omega = np.sqrt(k / m)
    dt = 0.05 / omega
    px = np.array([[0.5 * UM], [0.5 * UM], [1.0 * UM + R_C + 2 * v0 * dt]])
    pv = np.array([[0.0], [0.0], [-v0]])
    pairs = new_pair_memory(1)
    fp, _, out = _faces_step(mesh, faces, px, pv, pairs, dt)
    booked = out[4]
    for _ in range(400):
        pv += 0.5 * dt * fp / m
        px += dt * pv
        fp, _, out = _faces_step(mesh, faces, px, pv, pairs, dt)
        booked += out[4]
        pv += 0.5 * dt * fp / m
    assert pv[2, 0] == pytest.approx(v0, rel=2e-3) and booked == 0.0
