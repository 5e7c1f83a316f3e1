"""The explicit time loop of the 3D hexahedral engine (hexahedra with their material laws, element deletion,
cohesive interfaces, a rigid body's and the fragments' contact, the stability guard).

State (structure of arrays, SI): nodes ``X0`` (3, n) reference and ``x`` (3, n) current positions,
``v`` velocities (half step n+1/2 after a step), ``f`` the total nodal forces of the last step,
``mass`` lumped masses (rho V0 / 8 per element node), ``fix`` (3, n) uint8 prescribed dofs with
velocity ``vp`` (0 = fixed), ``fext`` (3, n) external nodal forces (held over a chunk);
elements ``hexes`` (ne, 8), ``mat`` (material row of ``cmat`` (nm, 6, 6) stiffnesses and ``rho``),
``pk2``, ``strain`` (ne, 6: xx, yy, zz, xy, yz, zx; 2nd Piola-Kirchhoff, Green-Lagrange with tensor
shears), ``eint`` stress work, ``ehg`` hourglass work, and the reference quantities of
:func:`solver.fem3d.hex8.reference_setup`. Tied nodes (``tie_nodes``): a node tied to a master moves
with it (the master integrates the group's force with the group's mass): plane-wave kinematics
with one element across, for instance.
Cohesive elements (optional, :func:`add_cohesive`; :mod:`.cohesive3d`): ``coh`` (nc, 8) node ids
(a0..a3, b0..b3), ``csign`` normal signs, ``carea`` reference areas, ``cp`` the law's
[K, sigma_n, tau, G_Ic, G_IIc, eta], per point damage ``dmg`` (nc, 4) and history ``chist``
(nc, 4, 4), per element ``cwork`` (work done on it), ``cdis`` (dissipation), ``cstate``
(0 intact, 1 debonded, 2 removed) and the force buffer ``fc`` (nc, 24). ``damping``: mass-proportional
damping c (the force -c m v on every free dof, as the 2D loop's), 0 by default.
A rigid body (optional, :func:`solver.fem3d.contact3d.add_tool` or ``add_sphere``; :mod:`.contact3d`):
``tool`` its array (empty: none), ``tool_par`` [kind, k, mu], the contact forces ``fcon``, ``fconp``
(3, n) of this and the last step, ``tool_now``, ``tool_out``, ``tool_en`` its forces and work.
Fragment contact (optional, :class:`solver.fem3d.contact3d.FragmentContact3D`): ``fr_faces`` the exposed
faces (empty: none), ``fr_nodes``, ``fr_par``, ``fr_cstart``, ``fr_cent``, ``fr_depth``, forces ``ffr``, ``ffrp``.

Materials: ``props`` (nm, N_PROPS3) the laws' table (:mod:`.laws3d`; default every row elastic), per element
the history ``hist`` (ne, N_HIST3), ``alive``, ``fail_mode`` (the 2D engine's mode numbers,
:data:`solver.fem.materials.MODE_NAMES`; negative: an overloaded EHM kept elastic) and ``fail_time`` (time
and step of the deletion). ``gpar``: deletion on, delete inverted elements, the guard's limits.

One step (central difference, Belytschko, Liu & Moran 2014, box 6.1):

    1. elements   (prange) stress (the element's law) and nodal forces at x^n into a per-element buffer fe
                  (ne, 24); a failing element's forces are dropped at once (:func:`_elements`)
    2. gather     (prange) f_i = sum of node i's entries of fe (node -> element incidence CSR, race
                  free, cost linear in the number of elements) + the external force;
                  cohesive elements (prange) into their buffer fc (nc, 24), added to f serially;
                  the rigid body's penalty contact (:func:`.contact3d.rigid_contact3d`) into fcon, added to f;
                  the fragments' (:func:`.contact3d.fragment_contact3d`) into ffr, added to f
    3. update     (prange) v^{n+1/2} = v^{n-1/2} + (dt_prev + dt)/2 f^n / m;  x^{n+1} = x^n + dt v^{n+1/2}
                  (prescribed dofs take their velocity; with damping c, f^n / m - c v^{n-1/2}); a non-finite
                  value is not written
    4. deletion   (:func:`_delete`) the failed elements stop acting for good; their nodes keep their mass
    5. guard      (:mod:`.guard3d`) NaN/Inf and inverted elements every step; the crushed-element step,
                  hourglass and energy checks every GUARD_EVERY steps (:func:`_guard_scan`)
                  the rigid body's work and friction booked, then it moves (:func:`.contact3d.book_body`)

The stable step is CFL x min(the living elements' critical step, the cohesive one): each cohesive point is
a spring k = K A0/4 between its two nodal masses, dt <= 2 / sqrt(k (1/m_a + 1/m_b)) (= 2 sqrt(m/K')
for equal masses m and k = K', as the 2D engine's :mod:`solver.fem.timestep`).

Energy booking (:func:`energies`): internal = stress work (trapezoidal in S : dE), hourglass = the
hourglass forces' work, kinetic = 1/2 m v^n . v^n with v^n = v^{n+1/2} - dt/2 f^n / m, external =
the work of the external forces and of the supports (trapezoidal over [x^{n-1}, x^n]), cohesive = the
work done on the cohesive elements (= their free energy + their dissipation + what neither accounts
for, reported as ``cohesive_unaccounted``), viscous = the damping's dissipation, c m v_mid^2 dt, deleted =
the stress and hourglass work held by elements when they were deleted (the 2D engine's 'removed'; the
failing step's trapezoid is cut to the forces that acted, as the 2D loop does); internal and hourglass
sum the living elements; with a rigid body (as the 2D engine's tool) external also holds its work on the
workpiece (``tool_work``), contact = the energy in its penalty springs (its work - the contact forces' work
on the nodes - friction), friction = the friction's dissipation; fragment_contact = the energy in the
fragments' penalty springs (minus the work they did on the nodes);
residual = initial + external - (internal + hourglass + kinetic + cohesive + viscous + deleted + contact +
friction + fragment_contact).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from ..threads import ThreadChoice, run_on
from .contact3d import FR_WORK, book_body, contact_energies, fragment_contact3d, no_fragments, no_tool, rigid_contact3d
from .cohesive3d import N_CH, cohesive3d_free_energy, cohesive3d_geometry, cohesive3d_update
from .hex8 import N_HGK, N_HQ, hex8_update, reference_setup
from .laws3d import N_HIST3, N_PROPS3, elastic_table
from .material3d import VOIGT, max_wave_speed

S_TIME, S_STEPS, S_DTPREV, S_NFAIL, S_NDEL, S_EHGMAX, S_HGRUN, S_EINIT, S_DT0 = range(9)
N_SCAL = 9
#: energy accounts: external work, viscous dissipation, energy held by elements when they were deleted
E_EXT, E_VISC, E_DEL = 0, 1, 2
#: guard parameters (``gpar``): deletion on, delete inverted elements, hourglass ratio limit, energy residual
#: limit, energy floor [J], erosion step [s] (0: off)
P_DELETE, P_INVDEL, P_HGMAX, P_EMAX, P_EFLOOR, P_ERODE = range(6)
#: guard codes (as the 2D engine's, solver.fem.loop)
G_OK, G_NAN, G_DT, G_HOURGLASS, G_INVERTED, G_ENERGY = 0, 1, 2, 3, 4, 5
#: the guard's energy, hourglass and step checks run every GUARD_EVERY steps (and on a chunk's last step)
GUARD_EVERY = 50
#: steps the hourglass ratio must stay above its limit before the guard fires (2D: HG_PERSIST)
HG_PERSIST = 1000

#: LLVM fast-math flags that keep IEEE NaN/Inf semantics (as the 2D loop)
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _elements(hexes, b0, vol0, hx, axes, hgk, hvis, x, v, cmat, props, mat, hist, alive, fail_mode, gpar, dtprev, pk2,
              strain, eint, ehg, hq, fe, dte, dcur):
    """Stress and nodal forces of the living elements (prange). A failing element (its law's mode > 0, or an
    inverted one when gpar[P_INVDEL]) is recorded in fail_mode, its forces no longer act from this step on,
    and the stress work its last forces counted (1/2) f^n . (x^n - x^{n-1}) is taken back, so the balance
    stays exact (the 2D loop's rule); a negative mode (an overloaded EHM, kept elastic) is only recorded.
    With erosion on (gpar[P_ERODE] > 0, deletion on) each element's current critical step (:func:`_det_f`'s
    scaling of its reference one) is kept in ``dcur``, and an element whose step fell below gpar[P_ERODE] is
    crushed: it fails as mode 9 (time-step erosion, LS-DYNA's ERODE/DTMIN; the 2D loop's rule).
    Returns (inverted elements not deleted, failing elements)."""
    ninv = 0
    nfail = 0
    check = gpar[P_DELETE] > 0.0
    invdel = gpar[P_INVDEL] > 0.0
    erode = gpar[P_ERODE] if check else 0.0
    for e in prange(hexes.shape[0]):
        if alive[e] == 0:
            continue
        inv, mode = hex8_update(e, hexes, b0, vol0, hx, axes, hgk, hvis, x, v, cmat, props, mat, hist, check, pk2,
                                strain, eint, ehg, hq, fe)
        if inv != 0:
            if invdel:
                mode = 9
            else:
                ninv += 1
                continue
        elif erode > 0.0:
            det, bb, bb0 = _det_f(e, hexes, b0, x)
            dc = dte[e] * math.sqrt(bb0 / bb) if det > 0.0 else 0.0
            dcur[e] = dc
            if mode == 0 and dc < erode:
                mode = 9  # crushed: its critical step fell below the erosion limit
        if mode < 0:
            if fail_mode[e] == 0:
                fail_mode[e] = mode
        elif mode > 0:
            fail_mode[e] = mode
            nfail += 1
            corr = 0.0
            for k in range(8):
                nd = hexes[e, k]
                corr += fe[e, 3 * k] * v[0, nd] + fe[e, 3 * k + 1] * v[1, nd] + fe[e, 3 * k + 2] * v[2, nd]
                fe[e, 3 * k] = 0.0
                fe[e, 3 * k + 1] = 0.0
                fe[e, 3 * k + 2] = 0.0
            eint[e] += 0.5 * dtprev * corr
    return ninv, nfail


@numba.njit(cache=True)
def _delete(hexes, alive, fail_mode, fail_time, eint, ehg, pk2, fe, scal, en, t, step, nlive, cmass):
    """Deletion phase (after the update): a failed element stops acting for good; its stored energy (stress +
    hourglass work) goes to the 'deleted' account; its failure time and step are kept. Its nodes keep their
    mass."""
    for e in range(hexes.shape[0]):
        if alive[e] != 0 and fail_mode[e] > 0:
            alive[e] = 0
            en[E_DEL] += eint[e] + ehg[e]
            fail_time[e, 0] = t
            fail_time[e, 1] = step
            for k in range(6):
                pk2[e, k] = 0.0
            for k in range(24):
                fe[e, k] = 0.0
            scal[S_NDEL] += 1.0
            for k in range(8):
                nd = hexes[e, k]
                nlive[nd] -= 1
                if nlive[nd] <= 0:
                    cmass[nd] = 0.0


@numba.njit(cache=True, inline="always")
def _det_f(e, hexes, b0, x):
    f00 = f01 = f02 = f10 = f11 = f12 = f20 = f21 = f22 = 0.0
    for I in range(8):
        n = hexes[e, I]
        bx = b0[e, I]
        by = b0[e, 8 + I]
        bz = b0[e, 16 + I]
        f00 += x[0, n] * bx
        f01 += x[0, n] * by
        f02 += x[0, n] * bz
        f10 += x[1, n] * bx
        f11 += x[1, n] * by
        f12 += x[1, n] * bz
        f20 += x[2, n] * bx
        f21 += x[2, n] * by
        f22 += x[2, n] * bz
    c00 = f11 * f22 - f12 * f21
    c01 = f12 * f20 - f10 * f22
    c02 = f10 * f21 - f11 * f20
    c10 = f02 * f21 - f01 * f22
    c11 = f00 * f22 - f02 * f20
    c12 = f01 * f20 - f00 * f21
    c20 = f01 * f12 - f02 * f11
    c21 = f02 * f10 - f00 * f12
    c22 = f00 * f11 - f01 * f10
    det = f00 * c00 + f01 * c01 + f02 * c02
    # |F^-T b0|^2 summed over the nodes, F^-T = cofactor / det
    bb = 0.0
    bb0 = 0.0
    for I in range(8):
        bx = b0[e, I]
        by = b0[e, 8 + I]
        bz = b0[e, 16 + I]
        gx = c00 * bx + c01 * by + c02 * bz
        gy = c10 * bx + c11 * by + c12 * bz
        gz = c20 * bx + c21 * by + c22 * bz
        bb += gx * gx + gy * gy + gz * gz
        bb0 += bx * bx + by * by + bz * bz
    if det > 0.0:
        bb /= det * det
    return det, bb, bb0


@numba.njit(cache=True)
def _first_inverted(hexes, b0, x, alive):
    for e in range(hexes.shape[0]):
        if alive[e] != 0 and not _det_f(e, hexes, b0, x)[0] > 0.0:
            return e
    return -1


@numba.njit(cache=True)
def _guard_scan(hexes, b0, dte, alive, eint, ehg, x, v, meff, slave, cwork, gpar, scal, en, guard, dt, cfl, every,
                contact_work):
    """The guard's checks on the configuration x^{n+1} (every GUARD_EVERY steps): the current critical step
    of each living element (its reference one times |b0| / |F^-T b0|, the Flanagan-Belytschko bound's
    scaling) against 1/100 of the initial step; hourglass energy against the largest element strain energy
    so far; the energy balance's residual. Returns the guard code (0: all well)."""
    step = scal[S_STEPS]
    t = scal[S_TIME]
    e_int = 0.0
    e_hg = 0.0
    dtmin = 1e300
    imin = -1
    ihg = -1
    vhg = -1.0
    for e in range(hexes.shape[0]):
        if alive[e] == 0:
            continue
        e_int += eint[e]
        e_hg += ehg[e]
        if ehg[e] > vhg:
            vhg = ehg[e]
            ihg = e
        det, bb, bb0 = _det_f(e, hexes, b0, x)
        if det > 0.0:
            dc = dte[e] * math.sqrt(bb0 / bb)
            if dc < dtmin:
                dtmin = dc
                imin = e
    if cfl * dtmin < 0.01 * scal[S_DT0]:
        guard[0] = G_DT
        guard[1] = imin
        guard[4] = cfl * dtmin / scal[S_DT0]
    e_tot = e_int + e_hg
    if e_tot > scal[S_EHGMAX]:
        scal[S_EHGMAX] = e_tot
    if scal[S_EHGMAX] > gpar[P_EFLOOR] and e_hg > gpar[P_HGMAX] * scal[S_EHGMAX]:
        scal[S_HGRUN] += every
    else:
        scal[S_HGRUN] = 0.0
    if guard[0] == 0 and scal[S_HGRUN] > HG_PERSIST:
        guard[0] = G_HOURGLASS
        guard[1] = ihg
        guard[4] = e_hg / scal[S_EHGMAX]
    if guard[0] == 0:
        ke = 0.0
        vmax = -1.0
        imax = -1
        for i in range(x.shape[1]):
            v2 = v[0, i] * v[0, i] + v[1, i] * v[1, i] + v[2, i] * v[2, i]
            ke += 0.5 * meff[i] * v2 if slave[i] == 0 else 0.0
            if v2 > vmax:
                vmax = v2
                imax = i
        held = e_int + e_hg + ke + en[E_DEL] + en[E_VISC]
        for c in range(cwork.shape[0]):
            held += cwork[c]
        given = scal[S_EINIT] + en[E_EXT] + contact_work  # the contacts' work on the nodes (their springs are not held)
        # the scale: energies that cannot be negative, so that an element that gave back more than it took
        # (booked negative when it is deleted) cannot shrink it
        scale = max(abs(scal[S_EINIT]) + abs(en[E_EXT]), e_int + e_hg + ke)
        if step > 10 and scale > gpar[P_EFLOOR] and abs(given - held) > gpar[P_EMAX] * scale:
            guard[0] = G_ENERGY
            guard[1] = imax  # the fastest node: where the energy is being made
            guard[4] = abs(given - held) / scale
    if guard[0] != 0:
        guard[2] = step
        guard[3] = t
        guard[5] = dt
    return int(guard[0])


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _gather(fe, nptr, nidx, fext, f):
    fe_flat = fe.ravel()
    for i in prange(f.shape[1]):
        sx = fext[0, i]
        sy = fext[1, i]
        sz = fext[2, i]
        for k in range(nptr[i], nptr[i + 1]):
            j = nidx[k]
            sx += fe_flat[j]
            sy += fe_flat[j + 1]
            sz += fe_flat[j + 2]
        f[0, i] = sx
        f[1, i] = sy
        f[2, i] = sz


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _cohesive(coh, csign, carea, cp, dmg, chist, cwork, cdis, cstate, x, v, dtprev, fc, f):
    """Cohesive forces (:mod:`.cohesive3d`) into fc (prange), then added to f (serial: nodes are shared).
    Returns the number of elements that became fully damaged."""
    nc = coh.shape[0]
    nfail = 0
    for c in prange(nc):
        if cohesive3d_update(c, coh, csign, carea, cp, dmg, chist, cwork, cdis, cstate, x, v, dtprev, fc) == 10:
            nfail += 1
    for c in range(nc):
        for k in range(8):
            nd = coh[c, k]
            f[0, nd] += fc[c, 3 * k]
            f[1, nd] += fc[c, 3 * k + 1]
            f[2, nd] += fc[c, 3 * k + 2]
    return nfail


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _chunk(n_steps, dt, hexes, b0, vol0, hx, axes, hgk, hvis, x, v, f, fp, meff, fix, vp, fext, fextp, tie_s,
               tie_m, slave, cmat, mat, pk2, strain, eint, ehg, hq, fe, nptr, nidx, scal, en, coh, csign, carea, cp, dmg,
               chist, cwork, cdis, cstate, fc, cdamp, props, hist, alive, fail_mode, fail_time, dte, dcur, gpar, guard, cfl,
               tool, tool_par, fcon, fconp, tool_now, tool_out, tool_en, fr_faces, fr_nodes, fr_par, fr_cstart, fr_cent,
               fr_depth, ffr, ffrp, nlive, cmass):
    """``n_steps`` explicit steps (module docstring), with the cohesive elements (none: ``coh`` empty),
    mass-proportional damping ``cdamp`` (0: none), the material laws' failures and element deletion, the
    stability guard (stops the chunk; ``guard`` holds the finding), a rigid body (none: ``tool`` empty), which
    touches only the nodes that still hold a living element (``cmass``: their mass, 0 for the others), and
    fragment contact (none: ``fr_faces`` empty)."""
    n = x.shape[1]
    done = 0
    ninv = 0
    for it in range(n_steps):
        dtprev = scal[S_DTPREV]
        ninv, nfail = _elements(hexes, b0, vol0, hx, axes, hgk, hvis, x, v, cmat, props, mat, hist, alive, fail_mode,
                                gpar, dtprev, pk2, strain, eint, ehg, hq, fe, dte, dcur)
        if ninv > 0:
            guard[0] = G_INVERTED
            guard[1] = _first_inverted(hexes, b0, x, alive)
            guard[2] = scal[S_STEPS]
            guard[3] = scal[S_TIME]
            guard[4] = ninv
            guard[5] = dt
            break
        _gather(fe, nptr, nidx, fext, f)
        if coh.shape[0] > 0:
            scal[S_NFAIL] += _cohesive(coh, csign, carea, cp, dmg, chist, cwork, cdis, cstate, x, v, dtprev, fc, f)
        has_body = tool.shape[0] > 0
        if has_body:
            _contact(x, v, cmass, tool, tool_par, fcon, fconp, tool_now, tool_en, dtprev, f, fix)
        if fr_faces.shape[0] > 0:
            _fragments(x, v, dtprev, fr_faces, fr_nodes, fr_par, fr_cstart, fr_cent, fr_depth, ffr, ffrp, f)
        for k in range(tie_s.shape[0]):  # a tied node's force acts on its master
            ts = tie_s[k]
            tm = tie_m[k]
            f[0, tm] += f[0, ts]
            f[1, tm] += f[1, ts]
            f[2, tm] += f[2, ts]
        dth = 0.5 * (dtprev + dt)
        wext = 0.0
        wvis = 0.0
        nnan = 0
        for i in prange(n):
            for c in range(3):
                # external forces' work over [x^{n-1}, x^n], trapezoidal
                wext += 0.5 * (fextp[c, i] + fext[c, i]) * v[c, i] * dtprev
                fextp[c, i] = fext[c, i]
            if slave[i] != 0:
                continue
            mi = meff[i]
            for c in range(3):
                if fix[c, i] != 0:
                    wext += -0.5 * (fp[c, i] + f[c, i]) * v[c, i] * dtprev  # the support's work
                    fp[c, i] = f[c, i]
                    vn = vp[c, i]
                elif mi > 0.0:
                    if cdamp > 0.0:
                        vn = v[c, i] + dth * (f[c, i] / mi - cdamp * v[c, i])
                        vm = 0.5 * (v[c, i] + vn)
                        wvis += cdamp * mi * vm * vm * dt
                    else:
                        vn = v[c, i] + dth * f[c, i] / mi
                else:
                    vn = v[c, i]
                xn = x[c, i] + dt * vn
                if not (math.isfinite(xn) and math.isfinite(vn)):
                    nnan += 1  # a non-finite value never enters the state
                    continue
                v[c, i] = vn
                x[c, i] = xn
        for k in range(tie_s.shape[0]):
            ts = tie_s[k]
            tm = tie_m[k]
            for c in range(3):
                v[c, ts] = v[c, tm]
                x[c, ts] += dt * v[c, tm]
        en[E_EXT] += wext
        en[E_VISC] += wvis
        t = scal[S_TIME]
        step = scal[S_STEPS]
        if has_body:
            book_body(tool, int(tool_par[0]), tool_now, tool_en, tool_out, dtprev, dt)
        scal[S_TIME] += dt
        scal[S_STEPS] += 1.0
        scal[S_DTPREV] = dt
        done += 1
        if nfail > 0:
            _delete(hexes, alive, fail_mode, fail_time, eint, ehg, pk2, fe, scal, en, t, step, nlive, cmass)
        if nnan > 0:
            guard[0] = G_NAN
            guard[1] = _first_nonfinite(x, v, f, meff, fix, dth, dt)
            guard[2] = step
            guard[3] = t
            guard[4] = nnan
            guard[5] = dt
            break
        if (int(scal[S_STEPS]) % GUARD_EVERY == 0 or it == n_steps - 1) and _guard_scan(
                hexes, b0, dte, alive, eint, ehg, x, v, meff, slave, cwork, gpar, scal, en, guard, dt, cfl,
                GUARD_EVERY, tool_en[1] + fr_par[FR_WORK]) != G_OK:
            break
    return done, ninv


@numba.njit(cache=True)
def _first_nonfinite(x, v, f, meff, fix, dth, dt):
    """The first node whose update went non-finite (its force, or its new velocity or position)."""
    for i in range(x.shape[1]):
        for c in range(3):
            vn = v[c, i] + dth * f[c, i] / meff[i] if (meff[i] > 0.0 and fix[c, i] == 0) else v[c, i]
            if not (math.isfinite(f[c, i]) and math.isfinite(vn) and math.isfinite(x[c, i] + dt * vn)):
                return i
    return -1


@numba.njit(cache=True)
def _contact(x, v, mass, tool, tool_par, fcon, fconp, tool_now, tool_en, dtprev, f, fix):
    """The rigid body's contact forces (:func:`.contact3d.rigid_contact3d`, its friction's trial from the other
    forces f on the free dofs) into fcon, added to f, and their work on the nodes over [x^{n-1}, x^n]
    (trapezoidal, v = v^{n-1/2}) into tool_en[1]."""
    rigid_contact3d(x, v, mass, tool, int(tool_par[0]), tool_par[1], tool_par[2], fcon, tool_now, dtprev, f, fix)
    tool_en[1] += _add_forces(fcon, fconp, v, dtprev, f)


@numba.njit(cache=True)
def _fragments(x, v, dtprev, fr_faces, fr_nodes, fr_par, fr_cstart, fr_cent, fr_depth, ffr, ffrp, f):
    """The fragments' contact forces (:func:`.contact3d.fragment_contact3d`) into ffr, added to f, and their
    work on the nodes over [x^{n-1}, x^n] (trapezoidal) into fr_par[FR_WORK]."""
    fragment_contact3d(x, v, dtprev, fr_faces, fr_nodes, fr_par, fr_cstart, fr_cent, fr_depth, ffr)
    fr_par[FR_WORK] += _add_forces(ffr, ffrp, v, dtprev, f)


@numba.njit(cache=True, inline="always")
def _add_forces(fnew, fprev, v, dtprev, f):
    """Add the contact forces fnew to f and return their work on the nodes over [x^{n-1}, x^n], trapezoidal in
    the force at v = v^{n-1/2}: sum (fprev + fnew)/2 . v dt (the module docstring's energy booking, as the
    external forces' work); fprev becomes fnew."""
    w = 0.0
    for i in range(f.shape[1]):
        for c in range(3):
            w += 0.5 * (fprev[c, i] + fnew[c, i]) * v[c, i] * dtprev
            fprev[c, i] = fnew[c, i]
            f[c, i] += fnew[c, i]
    return w


def compliance_tensors(cmat: np.ndarray) -> np.ndarray:
    """(nm, 3, 3, 3, 3) compliance tensors S_ijkl of the (nm, 6, 6) stiffnesses (engineering shears)."""
    out = np.zeros((cmat.shape[0], 3, 3, 3, 3))
    fac = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
    for m in range(cmat.shape[0]):
        S = np.linalg.inv(cmat[m]) / np.outer(fac, fac)
        for a, (i, j) in enumerate(VOIGT):
            for b, (k, l) in enumerate(VOIGT):
                for ii, jj in ((i, j), (j, i)):
                    for kk, ll in ((k, l), (l, k)):
                        out[m, ii, jj, kk, ll] = S[a, b]
    return out


class Hex8State:
    """Plain holder of the 3D engine's arrays (module docstring); build with :func:`build_state`."""

    def __repr__(self):
        return f"Hex8State(nodes={self.x.shape[1]}, elements={self.hexes.shape[0]}, time={self.time:.4g} s, steps={self.steps})"

    @property
    def time(self) -> float:
        return float(self.scal[S_TIME])

    @property
    def steps(self) -> int:
        return int(self.scal[S_STEPS])


def _incidence(hexes: np.ndarray, n: int):
    """node -> flat index (element * 24 + 3 * local) into the (ne, 24) force buffer, as CSR."""
    nodes = hexes.reshape(-1).astype(np.int64)
    flat = np.arange(nodes.size, dtype=np.int64) * 3
    order = np.argsort(nodes, kind="stable")
    ptr = np.zeros(n + 1, np.int64)
    np.add.at(ptr, nodes + 1, 1)
    return np.cumsum(ptr), flat[order]


def build_state(X, hexes, cmat, rho, mat=None, cfl: float = 0.9, hourglass_damping: float = 0.0, props=None,
                deletion: bool = True, delete_inverted: bool = False, hourglass_ratio_max: float = 0.1,
                energy_error_max: float = 0.5) -> Hex8State:
    """The engine state of a hexahedral mesh.

    X: (3, n) node coordinates [m]; hexes: (ne, 8) node ids (:mod:`.hex8` numbering, positive volume);
    cmat: (nm, 6, 6) stiffnesses [Pa] (:mod:`.material3d`), rho: (nm,) densities [kg/m^3], mat: (ne,)
    material rows (default 0); cfl: the step as a fraction of the critical step; hourglass_damping: the
    viscous hourglass part as a fraction of critical damping of each element's stiffest hourglass mode.
    props: (nm, N_PROPS3) the materials' laws (:mod:`.laws3d`, e.g. :func:`.laws3d.material_table3d`);
    default: every material elastic (never fails). deletion: evaluate the failure criteria and delete failed
    elements (off: the laws still flow and soften, nothing fails). delete_inverted: delete an inverted
    element (mode 9) instead of stopping the run. hourglass_ratio_max, energy_error_max: the guard's limits
    (as the 2D engine's, :mod:`solver.fem.guard`).
    """
    s = Hex8State()
    X = np.ascontiguousarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[0] != 3:
        raise ValueError(f"X has shape {X.shape}: need (3, n)")
    n = X.shape[1]
    s.hexes = np.ascontiguousarray(hexes, dtype=np.int32)
    ne = s.hexes.shape[0]
    if s.hexes.ndim != 2 or s.hexes.shape[1] != 8 or (ne and (s.hexes.min() < 0 or s.hexes.max() >= n)):
        raise ValueError(f"hexes: need (ne, 8) node ids in [0, {n})")
    s.cmat = np.ascontiguousarray(np.asarray(cmat, dtype=np.float64).reshape(-1, 6, 6))
    s.rho = np.ascontiguousarray(np.atleast_1d(np.asarray(rho, dtype=np.float64)))
    nm = s.cmat.shape[0]
    if s.rho.shape != (nm,) or not np.all(s.rho > 0):
        raise ValueError(f"rho = {s.rho.tolist()}: need {nm} positive densities")
    s.mat = np.zeros(ne, np.int32) if mat is None else np.ascontiguousarray(mat, dtype=np.int32)
    if s.mat.shape != (ne,) or (ne and (s.mat.min() < 0 or s.mat.max() >= nm)):
        raise ValueError(f"mat: need {ne} material rows in [0, {nm})")
    if not cfl > 0:
        raise ValueError(f"cfl = {cfl}: must be > 0")
    s.cmax = np.array([max_wave_speed(s.cmat[m], s.rho[m]) for m in range(nm)])
    s.X0 = X
    s.x = X.copy()
    s.v = np.zeros((3, n))
    s.f = np.zeros((3, n))
    s.fp = np.zeros((3, n))
    s.fix = np.zeros((3, n), np.uint8)
    s.vp = np.zeros((3, n))
    s.fext = np.zeros((3, n))
    s.fextp = np.zeros((3, n))
    s.b0 = np.zeros((ne, 24))
    s.vol0 = np.zeros(ne)
    s.hx = np.zeros((ne, 12))
    s.axes = np.zeros((ne, 9))
    s.hgk = np.zeros((ne, N_HGK))
    s.hvis = np.zeros(ne)
    s.dte = np.zeros(ne)
    bad = reference_setup(s.X0, s.hexes, s.mat, compliance_tensors(s.cmat), s.rho, s.cmax, float(hourglass_damping),
                          s.b0, s.vol0, s.hx, s.axes, s.hgk, s.hvis, s.dte)
    if bad >= 0:
        raise ValueError(f"hexes[{bad}] has a non-positive volume: number its nodes as solver.fem3d.hex8 says")
    s.props = elastic_table(nm) if props is None else np.ascontiguousarray(props, dtype=np.float64)
    if s.props.shape != (nm, N_PROPS3):
        raise ValueError(f"props has shape {s.props.shape}: need ({nm}, {N_PROPS3}) (solver.fem3d.laws3d)")
    s.hist = np.zeros((ne, N_HIST3))
    s.alive = np.ones(ne, np.uint8)
    s.fail_mode = np.zeros(ne, np.int32)
    s.fail_time = np.full((ne, 2), -1.0)  # time [s] and step of the deletion
    s.gpar = np.zeros(6)
    s.gpar[P_DELETE] = 1.0 if deletion else 0.0
    s.gpar[P_INVDEL] = 1.0 if delete_inverted else 0.0
    s.gpar[P_HGMAX] = float(hourglass_ratio_max)
    s.gpar[P_EMAX] = float(energy_error_max)
    s.guard = np.zeros(8)
    s.pk2 = np.zeros((ne, 6))
    s.strain = np.zeros((ne, 6))
    s.eint = np.zeros(ne)
    s.ehg = np.zeros(ne)
    s.hq = np.zeros((ne, N_HQ))
    s.fe = np.zeros((ne, 24))
    s.mass = np.zeros(n)
    np.add.at(s.mass, s.hexes.reshape(-1), np.repeat(0.125 * s.rho[s.mat] * s.vol0, 8))
    s.meff = s.mass.copy()
    s.nlive = np.bincount(s.hexes.reshape(-1), minlength=n).astype(np.int32)  # living elements per node
    s.cmass = s.meff.copy()  # a node's mass for the rigid body's contact (0 once no living element holds it)
    s.tie_s = np.zeros(0, np.int64)
    s.tie_m = np.zeros(0, np.int64)
    s.slave = np.zeros(n, np.uint8)
    s.nptr, s.nidx = _incidence(s.hexes, n)
    s.scal = np.zeros(N_SCAL)
    s.en = np.zeros(3)
    # the guard's energy checks wait until the energy in play exceeds that of a uniform strain of 1e-3 (2D's floor)
    s.gpar[P_EFLOOR] = 0.5e-6 * float((s.cmat[s.mat, 0, 0] * s.vol0).sum())
    s.damping = 0.0
    _set_cohesive(s, np.zeros((0, 8), np.int32), np.zeros(0), np.ones(0), np.zeros(6))
    no_tool(s)
    no_fragments(s)
    s.cfl = float(cfl)
    s.dt_crit = float(s.dte.min()) if ne else math.inf
    s.dcur = s.dte.copy()  # the current critical steps (kept with erosion on)
    s.scal[S_DT0] = s.cfl * s.dt_crit
    s.e_initial = None
    return s


def _set_cohesive(s, coh, area, sign, props):
    nc = coh.shape[0]
    s.coh = np.ascontiguousarray(coh, dtype=np.int32)
    s.carea = np.ascontiguousarray(area, dtype=np.float64)
    s.csign = np.ascontiguousarray(sign, dtype=np.float64)
    s.cp = np.ascontiguousarray(props, dtype=np.float64)
    s.dmg = np.zeros((nc, 4))
    s.chist = np.zeros((nc, 4, N_CH))
    s.cwork = np.zeros(nc)
    s.cdis = np.zeros(nc)
    s.cstate = np.zeros(nc, np.int8)
    s.fc = np.zeros((nc, 24))
    s.dt_cohesive = math.inf
    if nc:
        k = s.cp[0] * 0.25 * s.carea  # each point: a spring K A0 / 4 between its two nodal masses
        ma = s.mass[s.coh[:, :4]]
        mb = s.mass[s.coh[:, 4:]]
        s.dt_cohesive = float((2.0 / np.sqrt(k[:, None] * (1.0 / ma + 1.0 / mb))).min())


def add_cohesive(state: Hex8State, coh, props, debonded=None) -> None:
    """Join the mesh's node pairs by cohesive elements (:mod:`.cohesive3d`), before the first step.

    coh: (nc, 8) node ids a0..a3, b0..b3 (each pair at the same place, a0..a3 round the face; the
    normal's sign is taken from a hexahedron holding b0); props: [K, sigma_n, tau, G_Ic, G_IIc, eta] (SI);
    debonded: (nc,) bool, elements that start fully damaged (a pre-crack whose faces only resist
    interpenetration). Replaces any earlier cohesive elements; the stable step then includes their limit.
    """
    if state.steps:
        raise ValueError("add_cohesive: before the first step")
    coh = np.asarray(coh, dtype=np.int32).reshape(-1, 8)
    n = state.x.shape[1]
    if coh.size and (coh.min() < 0 or coh.max() >= n):
        raise ValueError(f"cohesive: need (nc, 8) node ids in [0, {n})")
    props = np.asarray(props, dtype=np.float64)
    if props.shape != (6,) or not np.all(props[:5] > 0) or props[5] <= 0:
        raise ValueError(f"cohesive props = {props.tolist()}: need [K, sigma_n, tau, G_Ic, G_IIc, eta], all > 0")
    area, sign = cohesive3d_geometry(state.X0, coh, state.hexes)
    _set_cohesive(state, coh, area, sign, props)
    if debonded is not None:
        deb = np.asarray(debonded, bool)
        state.dmg[deb] = 1.0
        state.cstate[deb] = 1


def tie_nodes(state: Hex8State, groups) -> None:
    """Tie each group of node ids to its first node (the master): they move together from now on.

    A tied node may not be prescribed itself (its master's dofs are); positions keep their offsets.
    """
    s_list, m_list = [], []
    for g in groups:
        g = [int(i) for i in g]
        for i in g[1:]:
            s_list.append(i)
            m_list.append(g[0])
    s = np.array(s_list, np.int64)
    m = np.array(m_list, np.int64)
    if np.unique(s).size != s.size or np.intersect1d(s, m).size:
        raise ValueError("tie_nodes: a node may be tied once, and a master may not itself be tied")
    state.tie_s, state.tie_m = s, m
    state.slave[:] = 0
    state.slave[s] = 1
    state.meff = state.mass.copy()
    np.add.at(state.meff, m, state.mass[s])
    state.cmass = state.meff.copy()
    for c in range(3):
        state.v[c, s] = state.v[c, m]


@dataclass
class StepRecord:
    steps: int
    time: float
    dt: float
    status: str = "ok"  # ok | inverted | unstable (the guard fired: ``finding``)
    inverted: int = 0
    debonded: int = 0  # cohesive elements that became fully damaged in this call (all four points)
    deleted: int = 0  # elements deleted in this call
    finding: dict | None = None  # the guard's diagnosis (solver.fem3d.guard3d), None when ok


def stable_dt(state: Hex8State) -> float:
    """CFL x the smallest critical step of the reference mesh's living elements (:mod:`.hex8`) and cohesive
    points (module docstring) [s], and at most the rigid body's contact limit (:mod:`.contact3d`)."""
    return min(state.cfl * min(state.dt_crit, state.dt_cohesive), state.dt_contact)


def _refresh_dt_crit(state: Hex8State) -> None:
    """A deleted element no longer counts in the stable step; with erosion on, the living elements' current
    critical steps (``dcur``, the deformed shapes') set it, as the 2D engine's step follows its elements."""
    live = state.alive != 0
    if live.any():  # with every element deleted the last step stays (free nodes move at constant velocity)
        steps = state.dcur if state.gpar[P_ERODE] > 0.0 else state.dte
        state.dt_crit = float(steps[live].min())


def advance(state: Hex8State, n_steps: int, dt: float | None = None, threads: int | None = None) -> StepRecord:
    """Run ``n_steps`` explicit steps in compiled code (:func:`_chunk`), of size ``dt`` (default
    :func:`stable_dt`; a larger one is refused). threads: numba threads for this call (default: the
    state's :class:`solver.threads.ThreadChoice`, which times the chunks on one and on all threads and
    runs on the faster; the results do not depend on it)."""
    from .guard3d import diagnosis

    n_steps = int(n_steps)
    if n_steps < 0:
        raise ValueError(f"n_steps = {n_steps}: must be >= 0")
    if state.guard[0] != G_OK:
        return StepRecord(0, state.time, float(state.scal[S_DTPREV]), "unstable", finding=diagnosis(state))
    dmax = stable_dt(state)
    dt = dmax if dt is None else float(dt)
    if not 0 < dt <= dmax * (1 + 1e-12):
        raise ValueError(f"dt = {dt:.4g} s: must be in (0, {dmax:.4g}] (CFL x the critical step)")
    if state.e_initial is None:
        e = energies(state)
        state.e_initial = e["kinetic"] + e["internal"] + e["hourglass"]
        state.scal[S_EINIT] = state.e_initial
    nfail0 = state.scal[S_NFAIL]
    ndel0 = state.scal[S_NDEL]

    def call():
        s = state
        return _chunk(n_steps, dt, s.hexes, s.b0, s.vol0, s.hx, s.axes, s.hgk, s.hvis, s.x, s.v, s.f, s.fp,
                      s.meff, s.fix, s.vp, s.fext, s.fextp, s.tie_s, s.tie_m, s.slave, s.cmat, s.mat, s.pk2,
                      s.strain, s.eint, s.ehg, s.hq, s.fe, s.nptr, s.nidx, s.scal, s.en, s.coh, s.csign, s.carea,
                      s.cp, s.dmg, s.chist, s.cwork, s.cdis, s.cstate, s.fc, float(s.damping), s.props, s.hist,
                      s.alive, s.fail_mode, s.fail_time, s.dte, s.dcur, s.gpar, s.guard, s.cfl, s.tool, s.tool_par, s.fcon,
                      s.fconp, s.tool_now, s.tool_out, s.tool_en, s.fr_faces, s.fr_nodes, s.fr_par, s.fr_cstart,
                      s.fr_cent, s.fr_depth, s.ffr, s.ffrp, s.nlive, s.cmass)

    if threads is None:
        done, ninv = thread_choice(state).run(call, steps_of=lambda r: r[0])
    else:
        done, ninv = run_on(threads, call)
    ndel = int(state.scal[S_NDEL] - ndel0)
    if ndel or state.gpar[P_ERODE] > 0.0:
        _refresh_dt_crit(state)
    code = int(state.guard[0])
    status = "ok" if code == G_OK else ("inverted" if code == G_INVERTED else "unstable")
    return StepRecord(int(done), state.time, dt, status, int(ninv), int(state.scal[S_NFAIL] - nfail0), ndel,
                      diagnosis(state) if code != G_OK else None)


def thread_choice(state: Hex8State) -> ThreadChoice:
    """The state's :class:`solver.threads.ThreadChoice` (made at its first chunk)."""
    choice = getattr(state, "thread_choice", None)
    if choice is None:
        choice = state.thread_choice = ThreadChoice()
    return choice


def nodal_forces(state: Hex8State) -> np.ndarray:
    """(3, n) total nodal forces (elements + external) at the current positions, without stepping or booking."""
    return evaluate(state)[0]


def evaluate(state: Hex8State) -> tuple[np.ndarray, np.ndarray]:
    """(total nodal forces (3, n), 2nd Piola-Kirchhoff stresses (ne, 6)) at the current positions, without
    stepping: the state's stresses, strains and booked energies are left as they were."""
    s = state
    held = (s.pk2, s.strain, s.eint, s.ehg, s.hq, s.dmg, s.chist, s.cwork, s.cdis, s.cstate, s.fc, s.hist,
            s.fail_mode, s.fe)
    keep = [a.copy() for a in held]
    f = np.zeros_like(s.f)
    _elements(s.hexes, s.b0, s.vol0, s.hx, s.axes, s.hgk, s.hvis, s.x, s.v, s.cmat, s.props, s.mat, s.hist, s.alive,
              s.fail_mode, s.gpar, 0.0, s.pk2, s.strain, s.eint, s.ehg, s.hq, s.fe, s.dte, s.dcur.copy())
    _gather(s.fe, s.nptr, s.nidx, s.fext, f)
    if s.coh.shape[0]:
        _cohesive(s.coh, s.csign, s.carea, s.cp, s.dmg, s.chist, s.cwork, s.cdis, s.cstate, s.x, s.v, 0.0, s.fc, f)
    pk2 = s.pk2.copy()
    for a, b in zip(held, keep):
        a[...] = b
    return f, pk2


def deformation_gradients(state: Hex8State) -> np.ndarray:
    """(ne, 3, 3) centroid deformation gradients F = sum_I x_I (x) b0_I."""
    b = state.b0.reshape(-1, 3, 8)
    xe = state.x[:, state.hexes]  # (3, ne, 8)
    return np.einsum("ieI,ejI->eij", xe, b)


def cauchy_stress(state: Hex8State) -> np.ndarray:
    """(ne, 6) Cauchy stress sigma = F S F^T / det F (xx, yy, zz, xy, yz, zx) of the last step."""
    F = deformation_gradients(state)
    S = np.zeros((F.shape[0], 3, 3))
    for a, (i, j) in enumerate(VOIGT):
        S[:, i, j] = state.pk2[:, a]
        S[:, j, i] = state.pk2[:, a]
    sig = np.einsum("eij,ejk,elk->eil", F, S, F) / np.linalg.det(F)[:, None, None]
    return np.stack([sig[:, i, j] for i, j in VOIGT], axis=1)


def energies(state: Hex8State) -> dict:
    """The energy balance at the last completed step n (module docstring) [J]."""
    s = state
    dt = float(s.scal[S_DTPREV])
    v = s.v.copy()
    free = (s.fix == 0) & (s.meff > 0)[None, :] & (s.slave == 0)[None, :]
    acc = np.divide(s.f, s.meff[None, :], out=np.zeros_like(s.f), where=s.meff[None, :] > 0)
    v[free] -= 0.5 * dt * acc[free]
    if s.tie_s.size:
        v[:, s.tie_s] = v[:, s.tie_m]
    live = s.alive != 0
    out = {"internal": float(s.eint[live].sum()), "hourglass": float(s.ehg[live].sum()),
           "kinetic": float(0.5 * (s.mass[None, :] * v * v).sum()), "external": float(s.en[E_EXT]),
           "deleted": float(s.en[E_DEL])}
    out["initial"] = (float(s.e_initial) if s.e_initial is not None
                      else out["kinetic"] + out["internal"] + out["hourglass"])
    held = out["internal"] + out["hourglass"] + out["kinetic"] + out["deleted"]
    nc = s.coh.shape[0]
    if nc or s.damping > 0 or s.en[E_VISC] != 0.0:
        out["cohesive"] = float(s.cwork.sum())
        out["cohesive_free"] = float(sum(cohesive3d_free_energy(c, s.carea, s.cp, s.dmg, s.chist) for c in range(nc)))
        out["cohesive_dissipated"] = float(s.cdis.sum())
        out["cohesive_unaccounted"] = out["cohesive"] - out["cohesive_free"] - out["cohesive_dissipated"]
        out["viscous"] = float(s.en[E_VISC])
        held = held + out["cohesive"] + out["viscous"]
    if s.tool.shape[0]:
        out.update(contact_energies(s))
        out["external"] += out["tool_work"]
        held = held + out["contact"] + out["friction"]
    if s.fr_faces.shape[0] or s.fr_par[FR_WORK] != 0.0:
        out["fragment_contact"] = -float(s.fr_par[FR_WORK])
        held = held + out["fragment_contact"]
    out["residual"] = out["initial"] + out["external"] - held
    scale = max(abs(out["initial"]) + abs(out["external"]), out["internal"] + out["hourglass"] + out["kinetic"], 1e-300)
    out["energy_error"] = abs(out["residual"]) / scale
    return out
