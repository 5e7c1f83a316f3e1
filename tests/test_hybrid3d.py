"""The hybrid3d fidelity: the 3D strip's failed hexahedra become SPH particles during the run.

A short cut of a shallow 0-degree strip (a few thousand steps; elements fail, convert, and the tool and the
surviving elements push their particles): the run is ok, every deleted fibre or matrix element became one
particle, mass is conserved to round-off (nodes + particles), the balance of engine and particles as one
body closes, the particle-face springs exchange work without making it, particles do not stay inside
living elements, and the tool force carries the particles' part. The verification case checks the
coupling's momentum and energy on a squeezed block.
"""

import numpy as np
import pytest

from solver.mesh import FIBRE, MATRIX
from solver.cutting import run_cutting
from solver.scene import load_scene

#: a shallow cut of the quick strip: 6 fibre rows instead of 19 (a third of the elements), long enough for
#: elements to fail and their particles to meet the tool
TINY = {"cut.length_um": 6.0, "cut.depth_um": 30.0, "workpiece.micro_zone_depth_um": 20.0, "workpiece.height_um": 100.0,
        "numerics.n_force_samples": 10, "numerics.n_frames": 1}


@pytest.fixture(scope="module")
def tiny():
    """(scene, result, the engine that ran it)."""
    from solver.hybrid.engine3d import Hybrid3dEngine

    built = []
    build = Hybrid3dEngine.build.__func__

    def keep(cls, *args, **kw):
        eng = build(cls, *args, **kw)
        built.append(eng)
        return eng

    mp = pytest.MonkeyPatch()
    mp.setattr(Hybrid3dEngine, "build", classmethod(keep))
    try:
        scene = load_scene("seed-0deg-hybrid3d-d01-quick", TINY)
        res = run_cutting(scene)  # without solver.run's warm-up cut (another engine)
    finally:
        mp.undo()
    assert len(built) == 1 and isinstance(built[0], Hybrid3dEngine)
    return scene, res, built[0]


def test_the_cut_runs_and_deleted_elements_become_particles(tiny):
    scene, res, eng = tiny
    assert res.status == "ok", res.diagnosis
    m = res.metrics
    state, c = eng.state, eng.coupler
    converting = np.isin(state.mat, [FIBRE, MATRIX])
    deleted = (state.alive == 0) & converting
    assert deleted.sum() > 0, "the cut must delete elements for this test to mean anything"
    assert m["n_converted_elements"] == int(deleted.sum()), "every deleted fibre or matrix element converted, once"
    assert m["n_particles"] + m["sph_escaped_particles"] == m["n_converted_elements"]
    assert res.build["modules"][0] == "solver.fem3d.strip3d" and "solver.sph3d" in res.build["modules"]
    # pieces separated by deleted elements touch through the fragments' contact, rebuilt as elements died
    assert eng.frag is not None and eng.frag.rebuilds > 0 and "rebuilt" in m["fragment_contact"]
    assert eng.state.fr_faces.shape[0] > 0
    fr = res.frames[-1]
    assert fr["particles_positions"].shape == (m["n_particles"], 3) and fr["positions"].shape[1] == 3


def test_mass_is_conserved_to_round_off(tiny):
    _, _, eng = tiny
    state, c = eng.state, eng.coupler
    m_elem = state.rho[state.mat] * state.vol0
    books = c.mass_books(state)
    total0 = float(m_elem.sum())  # the nodes' lumped masses at the start: each element's rho V0 in eighths
    assert books["nodes"] + books["particles"] + books["escaped"] == pytest.approx(total0, rel=1e-12, abs=0)
    # what the elements lost is what the particles carry
    assert books["particles"] + books["escaped"] == pytest.approx(float(m_elem[c.conv.converted].sum()), rel=1e-12)


def test_the_energy_balance_of_engine_and_particles_closes(tiny):
    _, res, _ = tiny
    m = res.metrics
    e = res.series["energies"]
    # the balance of the two as one body (its residual over the larger of inputs and stored energy)
    assert m["energy_error"] < 5e-3, m["energy_error"]
    # at every sample once the tool has done a tenth of its work (before, the error's scale is the round-off's)
    loaded = np.asarray(e["external"]) > 0.1 * e["external"][-1]
    assert np.max(np.asarray(e["energy_error_hybrid"])[loaded]) < 5e-3
    # the particles took part in it: they received energy from the tool and from the conversion
    assert m["sph_tool_work_J_per_m"] > 0.0
    assert e["sph_kinetic_received"][-1] > 0.0


def test_the_face_springs_exchange_work_without_making_it(tiny):
    _, res, _ = tiny
    m = res.metrics
    w_n, w_p = m["coupling_work_on_nodes_J_per_m"], m["coupling_work_on_particles_J_per_m"]
    assert m["sph_in_contact_with_faces_max"] > 0, "particles must touch surviving elements"
    assert abs(w_n) > 0.0
    # action = reaction: the nodes' and the particles' works cancel but for what the springs hold now
    assert abs(m["coupling_net_work_J_per_m"]) < 0.05 * max(abs(w_n), abs(w_p))


def test_particles_do_not_stay_inside_living_elements(tiny):
    _, res, _ = tiny
    m = res.metrics
    assert "sph_particles_inside_elements_max" in m  # counted at every force sample
    assert m["sph_particles_inside_elements_max"] <= max(1, 0.05 * m["n_particles"])
    assert m["sph_max_depth_inside_elements_um"] < m["sph_contact_radius_um"]


def test_the_tool_force_includes_the_particles_part(tiny):
    _, res, _ = tiny
    m = res.metrics
    f = res.series["forces"]
    assert "Fc_particles" in f and "Ft_particles" in f
    assert m["sph_max_tool_penetration_um"] > 0.0, "the tool touches particles"
    # the particles are pushed ahead of the tool: their force on it points along the cut, and is a part of the whole
    fc, fcp = np.asarray(f["Fc"]), np.asarray(f["Fc_particles"])
    assert fcp[-1] > 0.0
    assert np.all(fcp <= fc + 1e-12)


@pytest.mark.parametrize("deletion", [True, False])
def test_the_engine_has_the_interface_and_without_deletion_is_fem3d(deletion):
    from solver.engine import Engine, build_engine
    from solver.fem3d.strip3d import build_strip_mesh
    from solver.tool import tool_array

    scene = load_scene("seed-0deg-hybrid3d-d01-quick", {**TINY, "physics.element_deletion": deletion})
    si = scene.si()
    eng = build_engine(scene, si, build_strip_mesh(si), tool_array(si))
    assert isinstance(eng, Engine)
    assert type(eng).__name__ == ("Hybrid3dEngine" if deletion else "Fem3dEngine")
    assert eng.force_parts == ({"_particles": "sph"} if deletion else {})
    for p in ("", *eng.force_parts):
        assert eng.tool_force(p).shape == (8,)


def test_verification_case_squeezed_block_keeps_momentum():
    from solver.verification.hybrid3d_cases import case_momentum

    r = case_momentum({"n_steps": 800})
    assert r.passed, r.details
    assert r.details["momentum_change_rel"] < 1e-12
    assert r.details["energy_residual_rel_kinetic"] < 1e-3
    assert r.details["particles_in_contact_max"] > 0


def test_a_collapsed_particle_step_ends_the_run_unstable_with_the_particle(tiny):
    # a particle flung at 1e8 m/s sets a stable step far below the engine's: the chunk stops at once with the
    # particle, its speed and the time named (not a loop of vanishing steps, nor an exception)
    _, _, eng = tiny
    state, c = eng.state, eng.coupler
    P = c.particles
    assert P.n > 0
    i = P.n // 2
    v_keep, t0, steps0 = P.v[:, i].copy(), state.time, state.steps
    P.v[:, i] = [1e8, 0.0, 0.0]
    try:
        rec = c.advance(state, state.time + 1e-8, 100)
    finally:
        P.v[:, i] = v_keep
    assert rec.status == "unstable" and rec.finding["check"] == "dt_collapse"
    assert rec.finding["where"]["particle"] == i and "1e+08 m/s" in rec.finding["what"]
    assert rec.finding["dt_s"] < 1e-2 * c.dt_start
    assert state.time == t0 and state.steps == steps0


def test_the_cut_steps_the_same_on_one_and_on_two_threads(tiny):
    """The engine's and the particles' threads are chosen by timing (solver.threads), which is free only
    if it cannot change a result: the cut's engine with its particles, advanced the same steps on one and
    on two threads, bit for bit."""
    import copy

    import numba

    from solver.threads import ThreadChoice

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs two numba threads (NUMBA_NUM_THREADS=1 here)")
    _, _, eng = tiny
    assert eng.coupler.particles.n > 0
    runs = []
    for t in (1, 2):
        e = copy.deepcopy(eng)
        e.state.thread_choice = ThreadChoice(candidates=(t,))
        e.coupler.particles.threads = ThreadChoice(candidates=(t,))
        e.advance(e.state.time + 1e-7, 300)
        assert e.coupler.particles.threads.calls > 0 and e.state.thread_choice.calls > 0
        runs.append(e)
    a, b = runs
    assert a.state.time > eng.state.time
    for k in ("x", "v", "alive", "dmg", "en"):
        assert np.array_equal(getattr(a.state, k), getattr(b.state, k)), k
    for k in ("x", "v", "rho", "sig", "dmg", "est"):
        assert np.array_equal(getattr(a.coupler.particles, k), getattr(b.coupler.particles, k)), k


def test_the_particles_are_written_for_paraview(tiny, tmp_path):
    """A hybrid run's particles go into <run>-particles.xdmf beside the mesh's XDMF, read back with meshio:
    each frame's particle positions, material and damage by reference into the HDF5 file."""
    meshio = pytest.importorskip("meshio", reason="meshio is a test dependency (pyproject [test]); install .[test]")

    _, res, _ = tiny
    h5 = res.write_hdf5(tmp_path / "run.h5")
    xp = tmp_path / "run-particles.xdmf"
    assert h5.with_suffix(".xdmf").is_file() and xp.is_file()
    with_particles = [k for k, fr in enumerate(res.frames) if fr["particles_positions"].size]
    assert with_particles
    with meshio.xdmf.TimeSeriesReader(xp) as reader:
        points, cells = reader.read_points_cells()
        assert cells[0].type == "vertex"
        assert reader.num_steps == len(with_particles)
        t, point_data, _ = reader.read_data(0)
    first = res.frames[with_particles[0]]
    assert t == pytest.approx(res.frame_times[with_particles[0]])
    np.testing.assert_allclose(points, first["particles_positions"])
    np.testing.assert_array_equal(point_data["material"], first["particles_material"])
    np.testing.assert_array_equal(point_data["damage"], first["particles_damage"])
    assert 0.0 <= first["particles_damage"].min() and first["particles_damage"].max() <= 1.0
