"""Outputs of a cutting run on synthetic data with known answers."""

import math

import numpy as np
import pytest

from solver import load_scene
from solver.mesh import FIBRE, MATRIX
from solver.mesher import build_mesh
from solver.outputs import bounce_back, damage_depth, frame, frame_times, mean_forces, peak_forces
from solver.tool import tool_array


def test_mean_forces_average_the_given_window():
    travel = np.linspace(0, 100e-6, 101)
    fc = np.r_[np.zeros(50), np.full(51, 10.0)] + np.sin(travel * 1e6)  # transient then steady
    ft = -2.0 * np.ones_like(travel)
    m_fc, m_ft, win = mean_forces(travel, fc, ft, 100e-6, start=50e-6)
    assert m_fc == pytest.approx(10.0 + np.sin(travel[50:] * 1e6).mean())
    assert m_ft == -2.0 and win["samples"] == 51 and win["travel_from_um"] == pytest.approx(50.0)


def test_peak_forces_are_the_largest_samples_and_where_they_fall_ignoring_missing_samples():
    travel = np.linspace(-5.0, 95.0, 101)  # um
    fc = np.where(travel < 0, 0.0, 25.0 * np.exp(-((travel - 11.0) / 4.0) ** 2) + 4.0)  # engagement peak, then steady
    ft = np.r_[np.full(60, -1.0), np.full(41, 0.5)]
    fc[30] = np.nan  # a sample the run never reached
    p = peak_forces(travel, fc, ft)
    assert p["cutting"] == pytest.approx(29.0) and p["cutting_travel"] == pytest.approx(11.0)
    assert p["thrust"] == 0.5 and p["thrust_travel"] == pytest.approx(travel[60])  # the first of equal maxima
    empty = peak_forces(travel[:0], fc[:0], ft[:0])
    assert np.isnan(empty["cutting"]) and np.isnan(empty["thrust_travel"])


def test_damage_depth_is_the_deepest_failed_matrix_or_cohesive_below_the_plane():
    scene = load_scene("seed-0deg-fem-quick")
    si = scene.si()
    m = build_mesh(si)
    failed = np.zeros(m.n_elems, bool)
    coh = np.zeros(m.n_cohesive, bool)
    assert damage_depth(m, failed, coh, -si.depth) == 0.0
    cy = m.y[m.quads].min(1)
    # a failed fibre element deep down does not count; a matrix element 10 um below does
    fib = np.nonzero((m.material == FIBRE) & (cy < -si.depth - 30e-6))[0][0]
    failed[fib] = True
    assert damage_depth(m, failed, coh, -si.depth) == 0.0
    mat = np.nonzero((m.material == MATRIX) & (cy < -si.depth - 5e-6))[0]
    e = mat[np.argmax(cy[mat])]
    failed[e] = True
    assert damage_depth(m, failed, coh, -si.depth) == pytest.approx(-si.depth - cy[e])
    cyc = m.y[m.cohesive[:, :2]].min(1)
    k = np.argmin(cyc)
    coh[k] = True
    assert damage_depth(m, failed, coh, -si.depth) == pytest.approx(-si.depth - cyc[k])


def test_zone_depth_is_where_the_fibres_and_matrix_end_below_the_cut_plane():
    """The micro zone of the quick 90-degree scene reaches workpiece.micro_zone_depth_um below the cut plane (to
    within an element: the mesher rounds to whole fibre pitches or elements), and a matrix element failed at its
    bottom gives a damage depth that reaches it."""
    from solver.outputs import zone_depth

    for depth_um in (40.0, 80.0):
        si = load_scene("seed-90deg-fem-quick", {"workpiece.micro_zone_depth_um": depth_um,
                                                  "workpiece.height_um": 300}).si()
        m = build_mesh(si)
        zd = zone_depth(m, -si.depth)
        assert zd == pytest.approx(depth_um * 1e-6, abs=float(si.element_size))
        failed = np.zeros(m.n_elems, bool)
        cy = m.y[m.quads].min(1)
        failed[np.nonzero(m.material == MATRIX)[0][np.argmin(cy[m.material == MATRIX])]] = True
        assert damage_depth(m, failed, np.zeros(m.n_cohesive, bool), -si.depth) == pytest.approx(zd)


def test_bounce_back_measures_the_surface_above_the_tool_bottom():
    si = load_scene("seed-0deg-fem-quick").si()
    tool = tool_array(si, x_start=50e-6)
    x = np.linspace(0, 150e-6, 301)
    y_cut = -si.depth
    surf = y_cut + 3e-6  # surface 3 um above the cut plane behind the edge
    px = np.concatenate([x, x])
    py = np.concatenate([np.full_like(x, surf), np.full_like(x, surf - 20e-6)])
    bb, bins = bounce_back(px, py, np.ones(px.size, bool), tool, y_cut, 40e-6)
    assert bb == pytest.approx(3e-6) and bins == 8
    bb, bins = bounce_back(px, py, np.zeros(px.size, bool), tool, y_cut, 40e-6)
    assert np.isnan(bb) and bins == 0
    # only the machined surface counts: not what lies past the face where the tool entered
    xc, r = tool[0], tool[4]
    py_out = np.where(px > xc + r + 10e-6, surf - 50e-6, py)  # material pushed out beyond x_end, far below
    bb, bins = bounce_back(px, py_out, np.ones(px.size, bool), tool, y_cut, 40e-6, x_end=xc + r + 10e-6)
    assert bb == pytest.approx(3e-6) and bins == 2  # the bins keep their width (40 / 8 um): two lie on the surface
    # a cut shorter than the edge radius plus one element leaves no machined surface behind the edge
    bb, bins = bounce_back(px, py, np.ones(px.size, bool), tool, y_cut, 40e-6, x_end=xc + r + 2e-6, min_length=5e-6)
    assert np.isnan(bb) and bins == 0


def test_frames_hold_only_the_requested_fields():
    n_nodes, n_el = 5, 3
    f = frame(["positions", "state"], np.zeros(n_nodes), np.ones(n_nodes), np.zeros(n_el), np.array([0, 1, 0]),
              np.zeros(n_el), np.zeros((n_el, 3)))
    assert set(f) == {"positions", "state"} and f["positions"].shape == (5, 2) and f["state"].tolist() == [0, 1, 0]
    assert frame_times(1.0, 4).tolist() == [0.25, 0.5, 0.75, 1.0] and frame_times(1.0, 0).size == 0


def test_steady_start_cuts_the_engagement_transient():
    """A force that rises, overshoots and settles: the window starts after the overshoot (MSER-5), never in the
    rise, and never later than half the cut; pure noise keeps (almost) all of the cut."""
    from solver.outputs import steady_start

    rng = np.random.default_rng(3)
    travel = np.linspace(0.0, 200e-6, 401)
    steady = 10.0 + rng.normal(0.0, 1.0, travel.size)
    transient = np.where(travel < 20e-6, 30.0 * travel / 20e-6, 30.0 * np.exp(-(travel - 20e-6) / 8e-6))
    start = steady_start(travel, steady + transient, 200e-6)
    assert 40e-6 <= start <= 100e-6
    fc, ft, win = mean_forces(travel, steady + transient, 0 * travel, 200e-6)
    assert fc == pytest.approx(10.0, abs=0.3) and win["travel_from_um"] == pytest.approx(start * 1e6)
    noise_start = steady_start(travel, steady, 200e-6)
    assert noise_start <= 100e-6
    ramp = np.minimum(travel / 30e-6, 1.0) * 10.0 + rng.normal(0.0, 0.2, travel.size)
    assert steady_start(travel, ramp, 200e-6) >= 15e-6  # the rise is cut


def test_a_window_whose_force_still_falls_is_reported_as_not_settled():
    """steady_drift compares the window's two halves: white noise about a level is settled (|z| of order 1); a
    force that steps down from 20 to 6 N/mm at 70 % of the window (a layer breaking off) is not, with the
    drift its halves' difference over the window's mean; a small but significant drift (2 %) is settled."""
    from solver.outputs import steady_drift, steady_settled

    rng = np.random.default_rng(5)
    travel = np.linspace(0.0, 60e-6, 601)
    noise = rng.normal(0.0, 1.0, travel.size)
    drift, z = steady_drift(travel, 10.0 + noise, 0.0, 60e-6)
    assert abs(z) < 3.0 and abs(drift) < 0.05 and steady_settled(drift, z)
    broke = np.where(travel < 42e-6, 20.0, 6.0) + noise
    drift, z = steady_drift(travel, broke, 0.0, 60e-6)
    first, second = 20.0, (12e-6 * 20.0 + 18e-6 * 6.0) / 30e-6
    assert drift == pytest.approx((second - first) / broke.mean(), abs=0.03)
    assert z < -3.0 and not steady_settled(drift, z)
    slope = 10.0 + 0.2 * travel / 60e-6 + 0.01 * noise
    drift, z = steady_drift(travel, slope, 0.0, 60e-6)
    assert z > 3.0 and steady_settled(drift, z)
    assert all(math.isnan(v) for v in steady_drift(travel[:12], slope[:12], 0.0, 60e-6))
