"""The 3D strip mesher (solver.fem3d.strip3d): exact volumes, the fibre volume fraction, a conforming mesh
whose only internal surfaces are the cohesive fibre-matrix interfaces, correctly paired cohesive elements."""

import math

import numpy as np
import pytest

from solver.fem3d.cohesive3d import cohesive3d_geometry
from solver.fem3d.strip3d import StripSpec, build_strip, cell_section
from solver.mesh import EHM, FIBRE, MATRIX

_FACES = ((0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
_TETS = ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6))


def _volumes(X, hexes):
    """Hexahedron volumes as six tetrahedra about the diagonal 0-6 (exact for planar faces)."""
    P = X[:, hexes]
    v = 0.0
    for a, b, c, d in _TETS:
        v = v + np.einsum("ij,ij->j", P[:, :, b] - P[:, :, a], np.cross((P[:, :, c] - P[:, :, a]).T, (P[:, :, d] - P[:, :, a]).T).T) / 6
    return v


def _spec(theta, n):
    return StripSpec(theta, L=60e-6, H=50e-6, mz_depth=20e-6, x_ms=30e-6, h=5e-6, n_quarter=n, pitches=2)


@pytest.mark.parametrize("theta,n", [(0, 1), (0, 2), (90, 1), (90, 2)])
def test_volumes_fraction_and_conformity(theta, n):
    sp = _spec(theta, n)
    m = build_strip(sp)
    v = _volumes(m.X, m.hexes)
    assert v.min() > 0, "every hexahedron has positive volume (the hex8 numbering)"
    assert v.sum() == pytest.approx(sp.L * sp.H * sp.width, rel=1e-12)
    vf = v[m.material == FIBRE].sum() / v[(m.material == FIBRE) | (m.material == MATRIX)].sum()
    assert vf == pytest.approx(sp.vf, rel=1e-12), "the fibre polygon keeps the area pi r^2"
    assert sp.pitch == pytest.approx(sp.d_f * math.sqrt(math.pi / (4 * sp.vf)))
    # every face is shared by at most two hexahedra; a face of one lies on the box or on a cohesive surface
    count: dict = {}
    for row in m.hexes:
        for f in _FACES:
            k = tuple(sorted(row[list(f)]))
            count[k] = count.get(k, 0) + 1
    assert max(count.values()) == 2
    coh_faces = {tuple(sorted(r[:4])) for r in m.cohesive} | {tuple(sorted(r[4:])) for r in m.cohesive}
    lo = (0.0, -sp.H, 0.0)
    hi = (sp.L, 0.0, sp.width)
    n_outer = n_coh = 0
    for k, c in count.items():
        if c == 2:
            continue
        P = m.X[:, list(k)]
        on_box = any(np.allclose(P[a], lo[a], atol=1e-15) or np.allclose(P[a], hi[a], atol=1e-15) for a in range(3))
        assert on_box or k in coh_faces, f"face {k} is free inside the strip"
        n_outer += on_box
        n_coh += k in coh_faces and not on_box
    assert n_coh == 2 * m.n_cohesive
    assert set(np.unique(m.material)) == {FIBRE, MATRIX, EHM}


@pytest.mark.parametrize("theta", [0, 90])
def test_cohesive_pairs(theta):
    """Each cohesive element pairs coincident nodes on a fibre (side A) and the matrix (side B); its area
    sums to the fibres' lateral surface; its normal points from the fibre into the matrix."""
    sp = _spec(theta, 1)
    m = build_strip(sp)
    a, b = m.cohesive[:, :4], m.cohesive[:, 4:]
    # the two sides are distinct nodes, except where the fibre ends on the EHM (bonded there: 90 degrees)
    tied = a == b
    assert np.all(m.X[1, a[tied]] == pytest.approx(-sp.mz_depth))
    assert tied.sum() == (0 if theta == 0 else 2 * m.info["fibres"] * 8)
    assert np.abs(m.X[:, a] - m.X[:, b]).max() == 0.0
    area, sign = cohesive3d_geometry(m.X, m.cohesive, m.hexes)
    sec = cell_section(sp.pitch, sp.d_f, 1)
    ring = sec.pts[sec.surf_fibre]
    perimeter = np.linalg.norm(ring - np.roll(ring, -1, axis=0), axis=1).sum()
    length = sp.L if theta == 0 else sp.mz_depth
    assert area.sum() == pytest.approx(perimeter * length * m.info["fibres"], rel=1e-9)
    # side A's nodes belong to fibre elements only, side B's to matrix elements
    owner = {}
    for e, row in enumerate(m.hexes):
        for nd in row:
            owner.setdefault(int(nd), set()).add(int(m.material[e]))
    # the mesher names the fibre and the matrix hexahedron on either side of each cohesive element
    ce = m.cohesive_elems
    assert ce.shape == (m.n_cohesive, 2)
    assert np.all(m.material[ce[:, 0]] == FIBRE) and np.all(m.material[ce[:, 1]] == MATRIX)
    for c in range(m.n_cohesive):
        assert set(a[c]) <= set(m.hexes[ce[c, 0]]) and set(b[c]) <= set(m.hexes[ce[c, 1]])
    assert all(owner[int(nd)] == {FIBRE} for nd in np.unique(a[~tied]))
    assert all(FIBRE not in owner[int(nd)] for nd in np.unique(b[~tied]))


def test_symmetry_sides_and_errors():
    sp = _spec(0, 1)
    m = build_strip(sp)
    z0, z1 = m.nodes_on(2, 0.0), m.nodes_on(2, sp.width)
    assert len(z0) == len(z1) > 0
    with pytest.raises(ValueError, match="0 and 90 degrees"):
        build_strip(StripSpec(45, L=60e-6, H=50e-6))
    with pytest.raises(ValueError, match="height"):
        build_strip(StripSpec(0, L=60e-6, H=20e-6, mz_depth=30e-6))
    with pytest.raises(ValueError, match="inside its cell"):
        cell_section(7e-6, 7.5e-6)


def test_sections_and_plot(tmp_path):
    """A cross-section at a node level inside the strip shows each cell's O-grid twice (the elements on either
    side); the side z = 0 shows one face per boundary element; the figure is written."""
    from solver.fem3d.strip3d import faces_on, mid_section_value
    from solver.plots import plot_strip

    sp = _spec(0, 2)
    m = build_strip(sp)
    axis, value = mid_section_value(m)
    assert axis == 0 and 0 < value < sp.L
    quads, elems = faces_on(m.X, m.hexes, axis, value, 1e-12)
    sec = cell_section(sp.pitch, sp.d_f, 2)
    n_ehm = np.count_nonzero((m.material == EHM) & (np.abs(m.X[0, m.hexes].mean(axis=1) - value) < sp.h))
    assert len(quads) == 2 * len(sec.quads) * m.info["fibres"] + n_ehm
    side, _ = faces_on(m.X, m.hexes, 2, 0.0, 1e-12)  # the strip's side: each face once
    assert len(np.unique(np.sort(side, axis=1), axis=0)) == len(side)
    out = plot_strip(m, tmp_path / "strip.png")
    assert out.stat().st_size > 10_000


def test_plot_mesh_of_a_3d_scene(tmp_path):
    """`fibrecut plot-mesh` on a 3D scene draws its strip (side view and cross-section)."""
    from cli.main import main

    out = tmp_path / "mesh.png"
    assert main(["plot-mesh", "seed-90deg-fem3d-quick", "-o", str(out)]) == 0
    assert out.stat().st_size > 10_000
