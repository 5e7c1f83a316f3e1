"""The workpiece mesher: geometry, materials, cohesive interfaces and boundary conditions."""

import math

import numpy as np
import pytest

from solver import load_scene
from solver.mesh import EHM, FIBRE, MATRIX
from solver.mesher import _quad_area, build_mesh

QUICK = "seed-0deg-fem-quick"


def mesh_of(name=QUICK, **ov):
    scene = load_scene(name, {k.replace("__", "."): v for k, v in ov.items()})
    return scene, scene.si(), build_mesh(scene.si())


@pytest.mark.parametrize("angle", [0.0, 15.0, 30.0, 45.0, 60.0, 90.0, 120.0, 135.0, 165.0, 180.0])
def test_mesh_tiles_the_workpiece_with_positive_ccw_quads(angle):
    _, si, m = mesh_of(workpiece__fibre_angle_deg=angle)
    area = _quad_area(m.x, m.y, m.quads)
    assert np.all(area > 0), "every quad is counter-clockwise with positive area"
    assert math.isclose(area.sum(), si.length * si.height, rel_tol=1e-9)
    assert m.x.min() >= -1e-15 and m.x.max() <= si.length * (1 + 1e-12)
    assert m.y.max() <= 1e-15 and m.y.min() >= -si.height * (1 + 1e-12)
    assert set(np.unique(m.material)) == {FIBRE, MATRIX, EHM}
    # every node belongs to an element
    assert np.unique(m.quads).size == m.n_nodes


@pytest.mark.parametrize("angle", [0.0, 90.0])
def test_aligned_strips_have_the_scene_widths_and_volume_fraction(angle):
    scene, si, m = mesh_of(workpiece__fibre_angle_deg=angle, numerics__elements_across_fibre=3)
    mz = m.info["micro_zone"]
    cx, cy = m.x[m.quads].mean(1), m.y[m.quads].mean(1)
    inside = (cx > mz["x_min_m"] + 15e-6) & (cx < mz["x_max_m"] - 15e-6) & (cy > mz["y_min_m"] + 15e-6) & (cy < -15e-6)
    area = _quad_area(m.x, m.y, m.quads)
    vf = area[inside & (m.material == FIBRE)].sum() / area[inside & (m.material != EHM)].sum()
    assert abs(vf - scene.workpiece.fibre_volume_fraction) < 0.06
    # fibre elements: element_size along the fibre, d_f / 3 across
    e = np.nonzero(inside & (m.material == FIBRE))[0][0]
    xs, ys = m.x[m.quads[e]], m.y[m.quads[e]]
    along, across = (np.ptp(xs), np.ptp(ys)) if angle == 0 else (np.ptp(ys), np.ptp(xs))
    assert along <= si.element_size * (1 + 1e-9) and along > 0.5 * si.element_size
    assert math.isclose(across, si.fibre_diameter / 3, rel_tol=1e-9)


def test_micro_zone_spans_surface_to_below_the_cut_plane_over_the_cut_path():
    _, si, m = mesh_of()
    micro = m.material != EHM
    y_el = m.y[m.quads]
    x_el = m.x[m.quads]
    assert y_el[micro].max() == pytest.approx(0.0, abs=1e-12)
    assert y_el[micro].min() == pytest.approx(-(si.depth + si.micro_zone_depth), rel=0.1)
    assert x_el[micro].max() == pytest.approx(si.length)
    assert x_el[micro].min() <= si.length - si.cut_length


def test_cohesive_elements_join_duplicated_nodes_between_fibre_and_matrix():
    _, si, m = mesh_of(numerics__elements_across_fibre=2)
    assert m.n_cohesive > 0
    a0, a1, b0, b1 = m.cohesive.T
    # zero thickness: facing nodes start at the same place
    assert np.allclose(m.x[a0], m.x[b0]) and np.allclose(m.y[a0], m.y[b0])
    assert np.allclose(m.x[a1], m.x[b1]) and np.allclose(m.y[a1], m.y[b1])
    dup = (a0 != b0)
    assert dup.mean() > 0.9  # all but the tied ends at the micro zone's border are split
    ea, eb = m.cohesive_elems.T
    assert np.all(m.material[ea] == MATRIX) and np.all(m.material[eb] == FIBRE)
    for k in range(m.n_cohesive):  # each side's element really uses its side's nodes
        assert a0[k] in m.quads[ea[k]] and a1[k] in m.quads[ea[k]]
        assert b0[k] in m.quads[eb[k]] and b1[k] in m.quads[eb[k]]
    # no EHM element ever uses a duplicated node: the EHM shares nodes with the micro zone
    ehm_nodes = np.unique(m.quads[m.material == EHM])
    fib_only = np.setdiff1d(b0[dup], a0)
    assert np.intersect1d(ehm_nodes, fib_only).size == 0


def test_no_cohesive_interface_builds_no_cohesive_elements_nor_duplicates():
    _, si, m_on = mesh_of()
    _, _, m_off = mesh_of(physics__cohesive_interface=False)
    assert m_off.n_cohesive == 0 and m_off.cohesive_elems.shape == (0, 2)
    assert m_off.n_nodes < m_on.n_nodes and m_off.n_elems == m_on.n_elems


def test_bottom_and_far_end_fixed_top_free():
    _, si, m = mesh_of()
    fixed = m.fixed_x & m.fixed_y
    on_fixed_side = (np.abs(m.x) < 1e-12) | (np.abs(m.y + si.height) < 1e-12)
    assert np.array_equal(fixed, on_fixed_side) and np.array_equal(m.fixed_x, m.fixed_y)
    assert not fixed[np.abs(m.y) < 1e-12].all()  # the top is free (except its corner at x = 0)


def test_element_count_follows_element_size():
    # at 0 degrees the element size sets the columns along the fibre: length / h of them, on
    # length / h + 1 vertical node lines (halving the size doubles the columns)
    for h in (5.0, 2.5):
        _, si, m = mesh_of(physics__cohesive_interface=False, numerics__element_size_um=h)
        lines = np.unique(np.round(m.x / si.element_size, 6))
        assert lines.size - 1 == round(m.info["length_m"] / si.element_size)
        assert np.allclose(lines, np.round(lines))  # every node sits on one of them


@pytest.mark.parametrize("angle, offset_um", [(0.0, 5.0), (0.0, 10.0), (90.0, 5.0), (45.0, 3.0), (135.0, 3.0)])
def test_fibre_offset_shifts_the_strip_pattern_perpendicular_to_the_fibres(angle, offset_um):
    """workpiece.fibre_offset_um moves every fibre-matrix boundary by the offset, perpendicular to the
    fibres and into the workpiece: the boundaries' distances from the cut's start corner (L, 0),
    measured along the fibres' normal, are the unshifted ones plus the offset (mod one pitch)."""
    def boundaries(m):
        # signed distance of the fibre elements' centroids from the line through (L, 0) along the fibres
        th = math.radians(angle)
        nx, ny = math.sin(th), -math.cos(th)  # unit normal of the fibres, pointing into the workpiece:
        if (ny > 0) if abs(math.cos(th)) >= abs(math.sin(th)) else (nx > 0):  # down for flat fibres, -x for steep
            nx, ny = -nx, -ny
        cx, cy = m.x[m.quads].mean(1), m.y[m.quads].mean(1)
        interior = (cx > 10e-6) & (cx < si.length - 10e-6) & (cy < -10e-6) & (cy > -si.height + 10e-6)  # unclipped
        return (cx - si.length) * nx + cy * ny, (m.material == FIBRE) & interior

    scene, si, m0 = mesh_of(workpiece__fibre_angle_deg=angle)
    _, _, m1 = mesh_of(workpiece__fibre_angle_deg=angle, workpiece__fibre_offset_um=offset_um)
    pitch = si.fibre_diameter / si.fibre_volume_fraction
    (d0, f0), (d1, f1) = boundaries(m0), boundaries(m1)
    mz0 = (m0.material != EHM) & (d0 > 2 * pitch) & (d0 < 4 * pitch)
    mz1 = (m1.material != EHM) & (d1 > 2 * pitch) & (d1 < 4 * pitch)
    # a fibre centroid's phase within the pitch moves by the offset
    ph0 = np.unique(np.round((d0[mz0 & f0] % pitch) / pitch, 6))
    ph1 = np.unique(np.round(((d1[mz1 & f1] - offset_um * 1e-6) % pitch) / pitch, 6))
    assert ph0.size and np.allclose(np.sort(ph0), np.sort(ph1), atol=1e-6)
    # and the fibre fraction of the micro zone is unchanged
    assert abs(f1[m1.material != EHM].mean() - f0[m0.material != EHM].mean()) < 0.05


def test_fibre_offset_of_a_pitch_or_more_is_refused():
    from solver.scene import SceneError

    with pytest.raises(SceneError) as e:
        load_scene(QUICK, {"workpiece.fibre_offset_um": 12.5})
    assert "workpiece.fibre_offset_um" in str(e.value) and "12.5" in str(e.value)
