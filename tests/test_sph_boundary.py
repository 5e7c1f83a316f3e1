"""The mirror (ghost) clamp of solid SPH (solver.sph.boundary): ghosts placed from their partners
across the clamp face x = 0 (odd displacement and velocity), carrying the continued stress."""

import numpy as np
import pytest

from solver.sph import boundary, loop, materials as mt, particles as pp

from test_sph_solid import _velocity_gradient


def _block(dp=1e-3, vx=None, vy=None):
    """A block x in [-6 dp, 20 dp] x [0, 8 dp] whose particles at x < 0 are mirror ghosts across x = 0."""
    mats = mt.table(mt.isotropic(2e6, 0.3975, 1000.0))
    x, y = pp.lattice(-6 * dp, 20 * dp, 0.0, 8 * dp, dp)
    P = pp.from_points(x, y, mats, pp.make_params(dp), vx=0.0 if vx is None else vx(x, y),
                       vy=0.0 if vy is None else vy(x, y))
    idx, coef, ghost = boundary.mirror_pairs(x, y, 0.0, 1e-3 * dp)
    P.set_mirror(idx, coef)
    return P, x, y, ghost


def test_mirror_pairs_and_placement():
    """Each ghost is the reflection of its partner through the face (x_g = -x_p, y_g = 2 Y - y_p),
    with the opposite velocity, wherever the partner has moved; the ghosts are held FIXED."""
    P, x, y, ghost = _block()
    g, p1 = P.mirror_idx[0], P.mirror_idx[1]
    assert ghost.sum() == g.size == 6 * 8
    assert np.allclose(x[g], -x[p1]) and np.allclose(y[g], y[p1])
    assert (P.I[pp.FIXED, g] == 3).all() and (P.I[pp.FIXED, ~ghost] == 0).all()
    rng = np.random.default_rng(3)
    body = ~ghost
    P.F[pp.X, body] += 1e-4 * rng.standard_normal(body.sum())
    P.F[pp.Y, body] += 1e-4 * rng.standard_normal(body.sum())
    P.F[pp.VX, body] = rng.standard_normal(body.sum())
    P.F[pp.VY, body] = rng.standard_normal(body.sum())
    boundary.mirror_ghosts(P.F, P.mirror_idx, P.mirror_c)
    assert np.allclose(P.F[pp.X, g], -P.F[pp.X, p1], atol=1e-15)
    assert np.allclose(P.F[pp.Y, g], 2 * y[p1] - P.F[pp.Y, p1], atol=1e-15)
    assert np.array_equal(P.F[pp.VX, g], -P.F[pp.VX, p1]) and np.array_equal(P.F[pp.VY, g], -P.F[pp.VY, p1])


def test_a_body_at_rest_against_the_mirror_clamp_stays_at_rest():
    P, x, y, ghost = _block()
    rep = loop.step_chunk(P, 200, loop.stable_dt(P))
    assert rep.status == "ok"
    assert np.abs(P.F[pp.VX]).max() == 0.0 and np.abs(P.F[pp.VY]).max() == 0.0
    assert np.allclose(P.F[pp.X], x, rtol=0, atol=1e-15) and np.allclose(P.F[pp.Y], y, rtol=0, atol=1e-15)
    assert np.abs(P.F[pp.SXX]).max() == 0.0 and np.abs(P.F[pp.SXY]).max() == 0.0


def test_a_uniform_strain_rate_that_vanishes_on_the_face_is_reproduced_next_to_it():
    """v = (a x, c x) is zero on the clamp face; the ghosts continue it exactly (it is odd in x), so the
    corrected velocity gradient is exact at every body particle, those next to the face included. A
    fixed-particle clamp (v = 0 behind the face) gets the particles next to it wrong by tens of percent."""
    a, c = 0.7, -1.3
    G = np.array([[a, 0.0], [c, 0.0]])
    P, x, y, ghost = _block(vx=lambda x, y: a * x, vy=lambda x, y: c * x)
    L = _velocity_gradient(P)
    body = ~ghost
    assert np.allclose(L[:, :, body], G[:, :, None], rtol=0, atol=1e-9)
    # the same body with the clamp particles at rest
    mats = mt.table(mt.isotropic(2e6, 0.3975, 1000.0))
    Q = pp.from_points(x, y, mats, pp.make_params(1e-3), vx=np.where(ghost, 0.0, a * x), vy=np.where(ghost, 0.0, c * x),
                       fixed=ghost)
    Lf = _velocity_gradient(Q)
    near = body & (x < 2e-3)
    assert np.abs(Lf[0, 0, near] - a).max() > 0.1 * abs(a)


def test_the_ghosts_carry_the_stress_of_their_partners():
    """After a step the ghosts' state, acting and artificial stress, density and sound speed are
    those of their partners (the even continuation through the face), so the body next to the face
    feels the traction it transmits."""
    P, x, y, ghost = _block(vx=lambda x, y: 0.05 * np.maximum(x, 0) / 2e-2, vy=lambda x, y: 0.1 * np.maximum(x, 0) / 2e-2)
    rep = loop.step_chunk(P, 20, loop.stable_dt(P))
    assert rep.status == "ok"
    g, p1 = P.mirror_idx[0], P.mirror_idx[1]
    for r in (pp.SXX, pp.SYY, pp.SXY, pp.ESXX, pp.RHO, pp.CS):
        assert np.array_equal(P.F[r, g], P.F[r, p1])
    assert np.abs(P.F[pp.SXX, g]).max() > 0


def test_mirror_pairs_rejects_a_ghost_without_partner():
    x = np.array([-0.5, 0.5, -1.5])
    y = np.zeros(3)
    with pytest.raises(ValueError, match="no mirror partner"):
        boundary.mirror_pairs(x, y, 0.0, 1e-3)
