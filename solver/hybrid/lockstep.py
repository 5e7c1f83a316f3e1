"""The hybrid's lockstep coupling as one compiled multi-step loop (:func:`lockstep_steps`).

Each of its steps is one step of :meth:`solver.hybrid.coupler.HybridCoupler._lockstep`, composed of the
compiled pieces that step already calls, in the same order and with the same arithmetic: the
particles' stable step (:func:`solver.sph.loop.stable_dt`), one engine step (the FEM chunk
:func:`solver.fem.loop._chunk_impl` with the particles' reactions of the last step as the nodes'
external forces, their work booked as the coupling's work on the nodes), the boundary edges binned
where the engine left them (:func:`solver.contact._build_cells`), the living elements' Verlet list
around the particles (:func:`solver.sph.coupling.bin_elements`, rebuilt as
:meth:`HybridCoupler._element_bins` rebuilds it), one particle step with the tool where it was at the
step's start and the edge coupling (:func:`solver.sph.loop.advance`), the records of
:meth:`HybridCoupler._book` and the particles' part of the tool force. What happens rarely stays in
Python: the loop returns after the engine step when an element died (conversion and the new boundary)
or a particle left the escape box, after a step whose particles were put back out of an element (the
plastic impacts' pending impulses), and on any status other than ok; the caller takes the step after a
conversion or an escape in Python too (the particles' accelerations are recomputed there).

Results: the same as the Python step's to the last bit with the same compiled kernels
(``tests/test_hybrid_coupler.py``, and the quick D = 0.1 cut's summary). numba links the kernels a loop
calls into it, so a kernel compiled in another order or process can differ in the last bits under
fast-math, as any fresh compile can.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..contact import _build_cells
from ..fem.loop import G_OK, _chunk
from ..fem.state import E_EXT, P_CFL as FEM_P_CFL, S_DTCRIT, S_DTPREV, S_STEPS, S_TIME, TOOL_FORCE_ROWS
from ..sph.coupling import bin_elements
from ..sph.loop import CONTACT_OMEGA_DT, OK, advance as sph_advance
from ..sph.particles import P_CFL, P_DP, P_H, X, Y
from ..sph.solid import signal_dt

# why lockstep_steps returned (codes[0])
DONE = 0  # chunk_steps engine steps done, or t_stop reached
ENGINE_STOP = 1  # the engine's guard fired or it did no step: the caller ends the chunk
HANDOFF = 2  # after an engine step an element died or a particle left the escape box: the caller does the rest of the step
SPH_STOP = 3  # the particles' step ended with a status other than ok (codes[1]): the caller reports it
PENDING = 4  # particles were put back out of an element: the caller pends the nodes' impulses (jxn, jyn)

# the running records (acc), as on the coupler and the particles
A_NODE_WORK, A_SPH_STEPS, A_TOOL_WORK, A_COUPLE_WORK, A_IMPACT_LOSS, A_CONTACT_LOSS = 0, 1, 2, 3, 4, 5
A_N_EXPELLED, A_MAX_EXPEL, A_NO_FREE, A_NO_EDGE, A_MAX_OVERLAP, A_MAX_TOOL_PEN = 6, 7, 8, 9, 10, 11
A_DT_REACT, A_P_STEPS, A_P_TIME, A_BIN_BUILDS = 12, 13, 14, 15
ACC_SIZE = 16

_ROWS = TOOL_FORCE_ROWS


@numba.njit(cache=True)
def element_verlet_list(quads, live, x, y, node_active, pxmin, pymin, pxmax, pymax, reach, skin, dp, lbox, lx, ly,
                        lvalid, lstart, litems, lgrid):
    """The living elements (rows ``live`` of ``quads``) around the points in [pxmin, pxmax] x [pymin, pymax],
    within ``reach`` of that box, as a Verlet list (:func:`solver.sph.coupling.bin_elements`): the list
    (lstart, litems, lgrid) built for the box ``lbox`` = [x0, y0, x1, y1] from the nodes at lx, ly is kept
    while it is valid (lvalid != 0: no element died since), the box asked for lies inside lbox and no
    active node has moved more than half the skin along x or y; else it is built anew with the box and every
    element's bounding box grown by the skin, in cells of the particle spacing dp (coarser when the box
    would have more than 256 a side), lbox, lx, ly updated. A kept list holds every element a point asked
    about can be inside, and a few more that the exact point-in-quad test rejects. Returns (lstart, litems,
    lgrid, whether it was built)."""
    keep = lvalid != 0 and (lbox[0] <= pxmin - reach and lbox[1] <= pymin - reach
                            and lbox[2] >= pxmax + reach and lbox[3] >= pymax + reach)
    if keep:
        moved = 0.0
        for i in range(x.shape[0]):
            if node_active[i] != 0:
                moved = max(moved, abs(x[i] - lx[i]))
        for i in range(y.shape[0]):
            if node_active[i] != 0:
                moved = max(moved, abs(y[i] - ly[i]))
        if moved <= 0.5 * skin:
            return lstart, litems, lgrid, False
    margin = reach + skin
    bx0 = pxmin - margin
    by0 = pymin - margin
    bx1 = pxmax + margin
    by1 = pymax + margin
    bcell = max(dp, max(bx1 - bx0, by1 - by0) / 256.0)
    lstart, litems, lgrid = bin_elements(quads, live, x, y, bcell, bx0, by0, bx1, by1, skin)
    lbox[0] = bx0
    lbox[1] = by0
    lbox[2] = bx1
    lbox[3] = by1
    lx[:] = x
    ly[:] = y
    return lstart, litems, lgrid, True


@numba.njit(cache=True)
def lockstep_steps(chunk_steps, t_stop, nodes, elems, cohesive, blocks, cutter, frags, books,
                   F, I, S, A, act, n_act, mats, prm, order, cell_of, k_tool, mu, tool_sph, tout, sout, midx, mcen, Q,
                   edges, eitems, ebox, ecell, k_couple, r_c, v_sep, quads, live, nmass,
                   fxp, fyp, fxn, fyn, jxn, jyn, eout, expelled, pairs,
                   lstart, litems, lgrid, lbox, lx, ly, lvalid, skin, react, force_sum, acc, codes):
    """Up to ``chunk_steps`` lockstep steps of engine and particles (module docstring; the step of
    :meth:`solver.hybrid.coupler.HybridCoupler._lockstep` with one engine step per call and its particles'
    step :func:`solver.sph.loop.step_chunk` of one step), stopping once the engine's time reaches
    t_stop (1 - 1e-12).

    Engine: the bundles of :func:`solver.fem.loop._chunk_impl`; nodes.fext[0:2] take ``react`` (the
    particles' reactions on the nodes, float64[2, n_nodes], updated after each particle step). Particles:
    the arrays of :func:`solver.sph.loop.advance` (tool_sph float64[12], tout float64[10], sout float64[5]
    scratch). Edges: the boundary edges ``edges`` of the living elements ``live``, their cell list's items
    ``eitems``, the escape box ``ebox`` = [x0, x1, y0, y1], the edge cell ``ecell``, the penalty, contact
    radius and separation speed; the nodes' reactions and impulses fxn, fyn, jxn, jyn and the records
    eout, expelled (zeroed at every step). The living elements' Verlet list lstart, litems, lgrid built
    with the box ``lbox`` = [x0, y0, x1, y1] from the nodes at lx, ly (lvalid = 0: build it at the first
    step), skin ``skin``. ``force_sum`` += the particles' part of the tool force (rows TOOL_FORCE_ROWS),
    ``acc`` the running records (A_*). codes = [why it returned (DONE, ENGINE_STOP, HANDOFF, SPH_STOP,
    PENDING), the particles' status, engine steps done]. Returns the element list (lstart, litems,
    lgrid) in use at the end and lvalid (1 once it was built)."""
    params = books.params
    scal = books.scal
    en = books.en
    guard = books.guard
    x = nodes.x
    y = nodes.y
    fext = nodes.fext
    node_active = nodes.node_active
    alive = elems.alive
    tool = cutter.tool
    tool_out = cutter.tool_out
    nn = x.shape[0]
    ne = alive.shape[0]
    n_edges = edges.shape[0]
    h = prm[P_H]
    reach = 2.0 * ecell
    n_alive = 0
    for e in range(ne):
        n_alive += alive[e]
    codes[0] = DONE
    codes[1] = OK
    codes[2] = 0
    done = 0
    while done < chunk_steps and scal[S_TIME] < t_stop * (1 - 1e-12):
        # the particles' stable step caps the engine's (solver.sph.loop.stable_dt)
        dt_max = prm[P_CFL] * signal_dt(F, act, n_act, h)
        if k_tool > 0.0:
            dt_max = min(dt_max, CONTACT_OMEGA_DT / math.sqrt(k_tool))
        # one engine step, the reactions of the last particle step on the edge nodes (HybridCoupler._engine)
        for i in range(nn):
            fext[0, i] = react[0, i]
            fext[1, i] = react[1, i]
        w0 = en[E_EXT]
        s0 = scal[S_STEPS]
        _chunk(1, dt_max, t_stop, nodes, elems, cohesive, blocks, cutter, frags, books)
        acc[A_NODE_WORK] += en[E_EXT] - w0
        k = int(scal[S_STEPS] - s0)
        done += k
        codes[2] = done
        if guard[0] != G_OK or k == 0:
            codes[0] = ENGINE_STOP
            break
        n_now = 0
        for e in range(ne):
            n_now += alive[e]
        if n_now != n_alive:  # conversion and the new boundary: the caller
            codes[0] = HANDOFF
            break
        out_box = False  # HybridCoupler._escape
        for kk in range(n_act):
            i = act[kk]
            if F[X, i] < ebox[0] or F[X, i] > ebox[1] or F[Y, i] < ebox[2] or F[Y, i] > ebox[3]:
                out_box = True
        if out_box:
            codes[0] = HANDOFF
            break
        dt = scal[S_DTPREV]
        # the tool where it was at the particles' time (HybridCoupler._particles)
        for j in range(tool.shape[0]):
            tool_sph[j] = tool[j]
        tool_sph[0] -= tool_sph[2] * dt
        tool_sph[1] -= tool_sph[3] * dt
        tout[:] = 0.0
        # the edges binned where the engine left them (HybridCoupler._edge_contact)
        xmin = math.inf
        xmax = -math.inf
        ymin = math.inf
        ymax = -math.inf
        for r in range(n_edges):
            for c in range(2):
                nd = edges[r, c]
                xmin = min(xmin, x[nd])
                xmax = max(xmax, x[nd])
                ymin = min(ymin, y[nd])
                ymax = max(ymax, y[nd])
        x0 = max(xmin, ebox[0]) - ecell
        y0 = max(ymin, ebox[2]) - ecell
        ncx = int((min(xmax, ebox[1]) - x0) / ecell) + 2
        ncy = int((min(ymax, ebox[3]) - y0) / ecell) + 2
        estart = np.empty(ncx * ncy + 1, np.int64)
        _build_cells(x, y, edges, x0, y0, ecell, ncx, ncy, estart, eitems)
        dt_lim = scal[S_DTCRIT] * params[FEM_P_CFL]
        grid = np.array([x0, y0, ecell, float(ncx), float(ncy), k_couple, r_c, v_sep, dt_lim])
        # the living elements' Verlet list around the particles (HybridCoupler._element_bins)
        pxmin = math.inf
        pxmax = -math.inf
        pymin = math.inf
        pymax = -math.inf
        for kk in range(n_act):
            i = act[kk]
            pxmin = min(pxmin, F[X, i])
            pxmax = max(pxmax, F[X, i])
            pymin = min(pymin, F[Y, i])
            pymax = max(pymax, F[Y, i])
        lstart, litems, lgrid, built = element_verlet_list(quads, live, x, y, node_active, pxmin, pymin, pxmax, pymax,
                                                           reach, skin, prm[P_DP], lbox, lx, ly, lvalid, lstart,
                                                           litems, lgrid)
        if built:
            lvalid = 1
            acc[A_BIN_BUILDS] += 1.0
        # one particle step (solver.sph.loop.step_chunk)
        fxn[:] = 0.0
        fyn[:] = 0.0
        jxn[:] = 0.0
        jyn[:] = 0.0
        eout[:] = 0.0
        expelled[:] = 0.0
        sout[:] = 0.0
        sph_advance(F, I, S, A, act, n_act, mats, prm, order, cell_of, 1, dt, sout, 1, tool_sph, k_tool, 1, mu,
                    tout, 1, edges, quads, x, y, nodes.vx, nodes.vy, grid, estart, eitems, lgrid, lstart, litems,
                    fxp, fyp, fxn, fyn, jxn, jyn, eout, expelled, pairs, nmass, midx, mcen, Q)
        n_sph = int(sout[0])
        acc[A_P_STEPS] += n_sph
        acc[A_P_TIME] += n_sph * dt
        acc[A_SPH_STEPS] += n_sph
        acc[A_TOOL_WORK] += sout[4]
        # HybridCoupler._book
        acc[A_COUPLE_WORK] += eout[2] + expelled[2]
        acc[A_IMPACT_LOSS] += expelled[5]
        acc[A_CONTACT_LOSS] += eout[3] + expelled[6]
        acc[A_N_EXPELLED] += int(expelled[0])
        acc[A_MAX_EXPEL] = max(acc[A_MAX_EXPEL], expelled[1])
        acc[A_NO_FREE] += int(expelled[3])
        acc[A_NO_EDGE] += int(expelled[4])
        if eout[1] > 0:
            acc[A_MAX_OVERLAP] = max(acc[A_MAX_OVERLAP], eout[0])
        status = int(sout[1])
        if status == OK:
            # the particles' part of the tool force joins the engine's (steps of the same length)
            scale = dt / dt
            for j in range(_ROWS.shape[0]):
                f = tout[_ROWS[j]] * scale
                tool_out[_ROWS[j]] += f
                force_sum[j] += f
            acc[A_MAX_TOOL_PEN] = max(acc[A_MAX_TOOL_PEN], tout[2])
            tool_out[3] += tout[3] * dt
        for i in range(nn):
            react[0, i] = fxn[i]
            react[1, i] = fyn[i]
        acc[A_DT_REACT] = dt
        if status != OK:
            codes[0] = SPH_STOP
            codes[1] = status
            break
        if expelled[0] > 0:
            codes[0] = PENDING
            break
    return lstart, litems, lgrid, lvalid
