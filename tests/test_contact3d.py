"""Contact in the 3D engine (solver/fem3d/contact3d.py): the 2D tool extruded along z, a rigid sphere, the
symmetry planes, and the contact phase of the compiled loop with its energy booking.

References: the 2D engine's own tool contact (solver.contact.tool_contact) for the extruded tool's forces,
the sphere's exact distance, plane strain (no z-motion, both faces of a strip alike), the energy balance,
Coulomb's law for a sliding contact, and Hertz's point contact (Johnson 1985, sec. 4.2) on a coarse mesh,
whose error falls as the mesh is refined.
"""

import numpy as np
import pytest

from solver.contact import tool_contact
from solver.fem3d import contact3d, gridmesh3d, loop, material3d
from solver.verification import contact3d_cases as cases
from solver.verification.contact_cases import EPOXY, edge_tool


def _random_nodes(n, seed=0):
    rng = np.random.default_rng(seed)
    x = np.vstack([rng.uniform(-3e-6, 3e-6, n), rng.uniform(-3e-6, 4e-6, n), rng.uniform(0.0, 5e-6, n)])
    v = np.vstack([rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), np.zeros(n)])
    return x, v, rng.uniform(1e-12, 2e-12, n)


def test_the_extruded_tool_gives_the_2d_tools_forces_at_every_z():
    tool = edge_tool(0.0, -0.5e-6, 2e-6, clearance_deg=7.0)
    tool[2], tool[3] = -3.0, 0.5
    x, v, m = _random_nodes(400)
    k, mu = 1e20, 0.4
    f3 = np.zeros((3, 400))
    out3 = np.zeros(contact3d.N_OUT)
    contact3d.rigid_contact3d(x, v, m, tool, contact3d.KIND_TOOL, k, mu, f3, out3)
    fx, fy, out2 = np.zeros(400), np.zeros(400), np.zeros(10)
    tool_contact(x[0].copy(), x[1].copy(), v[0].copy(), v[1].copy(), m, np.ones(400, np.uint8), tool, k, mu, fx, fy,
                 out2, 1)
    assert np.count_nonzero(fx) > 50  # many nodes in contact, on every face
    assert np.all(np.abs(out3[5:14].reshape(3, 3)).sum(axis=1) > 0.0)
    np.testing.assert_allclose(f3[0], fx, rtol=1e-12, atol=0)
    np.testing.assert_allclose(f3[1], fy, rtol=1e-12, atol=0)
    assert np.all(f3[2] == 0.0)
    np.testing.assert_allclose(out3[[0, 1, 3, 4]], out2[[0, 1, 2, 3]], rtol=1e-12)
    np.testing.assert_allclose(out3[5:14].reshape(3, 3)[:, :2], out2[4:10].reshape(3, 2), rtol=1e-12, atol=1e-30)


def test_the_sphere_distance_and_normal_are_exact():
    body = np.zeros(contact3d.N_BODY)
    body[0], body[1], body[5], body[4] = 1.0, 2.0, 3.0, 0.5
    rng = np.random.default_rng(1)
    for _ in range(20):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        r = rng.uniform(0.1, 1.0)
        p = np.array([1.0, 2.0, 3.0]) + r * d
        sd, nx, ny, nz = contact3d.sphere_sdf(p[0], p[1], p[2], body)
        assert sd == pytest.approx(r - 0.5, abs=1e-14)
        np.testing.assert_allclose([nx, ny, nz], d, atol=1e-14)


def test_symmetry_planes_hold_only_the_nodes_on_them_along_their_normal():
    mesh = gridmesh3d.box_mesh(3, 2, 4, 3.0, 2.0, 4.0)
    s = loop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(1e9, 0.3)], [1000.0])
    a, b = contact3d.strip_sides(s)
    on = np.isclose(mesh.X[2], 0.0) | np.isclose(mesh.X[2], 4.0)
    assert set(a) | set(b) == set(np.nonzero(on)[0])
    assert np.all(s.fix[2] == on) and not s.fix[:2].any()
    with pytest.raises(ValueError):
        contact3d.symmetry_plane(s, 0, 0.5)  # no node there


def _strip_under_tool(mu, nx=12, ny=4):
    h = 1e-6
    mesh = gridmesh3d.box_mesh(nx, ny, 1, nx * h, ny * h, h, origin=(0.0, -ny * h, 0.0))
    s = loop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(EPOXY["E"], EPOXY["nu"])], [EPOXY["rho"]])
    s.fix[:, mesh.X[1] < -ny * h * (1 - 1e-9)] = 1
    contact3d.strip_sides(s)
    contact3d.add_tool(s, edge_tool(0.5 * nx * h + 0.5 * h, 0.0, 3 * h), mu=mu)
    contact3d.set_body_velocity(s, -0.5, -1.0)  # into the strip and along it
    return s, mesh, h


def test_a_strip_with_held_sides_under_the_tool_deforms_in_plane_strain_and_its_energy_balances():
    s, mesh, h = _strip_under_tool(0.0)
    rec = loop.advance(s, 600, threads=1)
    assert rec.status == "ok"
    assert s.tool_out[3] > 0.01 * h  # in contact
    u = s.x - s.X0
    front, back = mesh.X[2] < 0.5 * h, mesh.X[2] > 0.5 * h
    assert np.abs(u[2]).max() == 0.0
    assert np.abs(u[:2, front] - u[:2, back]).max() < 1e-9 * np.abs(u).max()
    e = loop.energies(s)
    assert e["tool_work"] > 0 and e["contact"] > 0 and e["friction"] == 0.0
    assert e["energy_error"] < 1e-4, e
    by = contact3d.tool_force_by_face(s)
    total = sum(by[k] for k in ("rake", "edge", "clearance"))
    np.testing.assert_allclose(total, by["total"], rtol=1e-12)
    assert by["edge"][1] > 0  # the strip pushes the edge up


def test_without_a_body_the_contact_state_is_empty_and_stays_zero():
    mesh = gridmesh3d.box_mesh(2, 2, 2, 1.0, 1.0, 1.0)
    s = loop.build_state(mesh.X, mesh.hexes, [material3d.isotropic_stiffness(1e9, 0.3)], [1000.0])
    s.v[0] = 0.01 * mesh.X[1]
    loop.advance(s, 20, threads=1)
    assert s.tool.shape == (0,) and not s.fcon.any() and not s.tool_en.any()
    assert "contact" not in loop.energies(s)
    assert loop.stable_dt(s) == s.cfl * s.dt_crit


def test_sliding_under_the_tool_gives_coulombs_ratio():
    mu = 0.25
    r = cases.slide(mu, nx=16, ny=4, travel=2.0)
    assert r["Fy_N"] > 0 and r["Fz_N"] == 0.0
    assert abs(r["ratio"] - mu) / mu < 0.01, r
    assert r["friction_J"] == pytest.approx(r["tangential_work_J"], rel=1e-3)  # booked as dissipated
    assert r["energy_error"] < 1e-6, r


def test_the_3d_edge_reproduces_the_2d_tool_hertz_case_on_a_coarse_mesh():
    r = cases.case_tool_bridge({"a_over_h": 2.0, "periods": 3.0, "hold": 3.0})
    d = r.details
    assert d["error_a_vs_2d"] < 0.01 and d["error_P_vs_2d"] < 0.01, d
    assert d["plane_strain_z_m_3d"] == 0.0 and d["plane_strain_xy_3d"] < 1e-9, d


def test_the_sphere_approaches_hertz_as_the_mesh_is_refined():
    e = [cases.press_sphere(**{**cases.SPHERE, "a_over_h": a})["error"] for a in (2.0, 4.0)]
    assert e[1] < e[0], e
    assert e[1] < 0.08, e  # 7.1 % at 4 elements across the contact radius (docs/numerics.md)


def _two_blocks(v0):
    a = gridmesh3d.box_mesh(2, 2, 2, 2.0, 2.0, 2.0)
    b = gridmesh3d.box_mesh(2, 2, 2, 2.0, 2.0, 2.0, origin=(0.3, 0.2, 2.02))
    s = loop.build_state(np.hstack([a.X, b.X]), np.vstack([a.hexes, b.hexes + a.n_nodes]),
                         [material3d.isotropic_stiffness(1e6, 0.3)], [1000.0])
    s.v[2, :a.n_nodes] = v0
    s.v[2, a.n_nodes:] = -v0
    return s, a.n_nodes


def test_two_blocks_meeting_bounce_apart_with_momentum_kept_and_energy_balanced():
    s, na = _two_blocks(0.2)
    fc = contact3d.FragmentContact3D(s)
    fc.rebuild(s)
    assert s.fr_faces.shape[0] == 48 and s.fr_nodes.shape[0] == 52  # 2 x 24 faces, 2 x 26 nodes
    p0 = (s.mass * s.v).sum(axis=1)
    overlap = 0.0
    while s.time < 0.6:
        assert loop.advance(s, 10, threads=1).status == "ok"
        fc.grow(s)
        overlap = max(overlap, s.x[2, :na].max() - s.x[2, na:].min())
    p1 = (s.mass * s.v).sum(axis=1)
    assert np.abs(p1 - p0).max() < 1e-12 * (s.mass.sum() * 0.2)  # action = reaction
    assert s.fr_par[contact3d.FR_DEEP] > 0  # they touched
    assert overlap < 0.1  # a tenth of an element at most
    assert s.v[2, :na].mean() < -0.1 and s.v[2, na:].mean() > 0.1  # and bounced apart
    e = loop.energies(s)
    assert e["energy_error"] < 1e-2, e


def test_without_fragment_contact_the_blocks_pass_through_each_other():
    s, na = _two_blocks(0.2)
    while s.time < 0.6:
        loop.advance(s, 10, threads=1)
    assert s.x[2, :na].max() - s.x[2, na:].min() > 0.1


def test_the_faces_of_intact_cohesive_elements_are_not_exposed():
    m = gridmesh3d.split_box_mesh(3, 2, 1, 1, 3.0, 2.0, 1.0, 1.0)
    s = loop.build_state(m.X, m.hexes, [material3d.isotropic_stiffness(1e6, 0.3)], [1000.0])
    loop.add_cohesive(s, m.cohesive, [1e9, 1e3, 1e3, 1.0, 1.0, 2.0])
    fc = contact3d.FragmentContact3D(s)
    total = fc.faces.shape[0]
    assert fc.exposed(s).shape[0] == total - 2 * m.n_cohesive
    s.cstate[:2] = 1  # two debonded: their four faces are surfaces again
    assert fc.exposed(s).shape[0] == total - 2 * m.n_cohesive + 4


def test_a_deleted_element_exposes_its_neighbours_faces_and_the_sides_stay_out():
    m = gridmesh3d.box_mesh(3, 1, 1, 3.0, 1.0, 1.0)  # three cubes in a row along x, z from 0 to 1
    s = loop.build_state(m.X, m.hexes, [material3d.isotropic_stiffness(1e6, 0.3)], [1000.0])
    fc = contact3d.FragmentContact3D(s)
    assert fc.exposed(s).shape[0] == 14 and not fc.needs_rebuild(s)  # nothing separated: nothing to build
    s.alive[1] = 0  # the middle cube deleted: two separate cubes of 6 faces each
    assert fc.needs_rebuild(s)
    f = fc.exposed(s)
    assert f.shape[0] == 12 and not np.any(f[:, 4] == 1)
    fc.rebuild(s)
    assert s.fr_faces.shape[0] == 12 and not fc.needs_rebuild(s)
    sided = contact3d.FragmentContact3D(s, sides=(0.0, 1.0))  # the z faces of both cubes left out
    assert sided.exposed(s).shape[0] == 8
