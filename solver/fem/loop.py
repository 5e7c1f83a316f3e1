"""The explicit time loop: compiled chunks of central-difference steps.

One step (Belytschko, Liu & Moran 2014, box 6.1, with a variable step), one function per phase:

    1. elements   (:func:`_elements`) stress at x^n, nodal forces into a per-element buffer, critical
                  step, failures (with deletion on, an element whose critical step fell below
                  params[P_ERODE] is crushed and deleted: time-step erosion, e.g. LS-DYNA's ERODE/DTMIN)
    2. cohesive   (:func:`_cohesive`) openings, damage, tractions into a per-cohesive buffer
    3. gather     (:func:`_gather`) f_i = sum of the buffers' entries of node i (node -> buffer CSR; race free)
    4. contact    (:func:`_tool_contact`) the rigid tool (solver.contact.tool_contact) adds its forces
                  (kept apart to book the work they do on the body: the penalty spring's energy is the
                  difference); (:func:`_fragment_contact`) fragments split off by deleted elements push on
                  each other (solver.contact.fragment_contact_step; their work is booked the same way)
    5. step size  (:func:`_block_totals`, :func:`_step_size`) dt = CFL x min(element, cohesive, contact
                  critical steps), capped by the caller's dt; (:func:`_guard_configuration`) the guard's
                  checks on x^n: inverted element, time-step collapse, hourglass energy
    6. update     (:func:`_update`) v^{n+1/2} = v^{n-1/2} + (dt_prev + dt)/2 (f/m - c v);
                  x^{n+1} = x^n + dt v^{n+1/2} (prescribed dofs take their velocity); the work of the
                  tool, the fragments, the external forces and the supports, and the damping, are booked
    7. tool       (:func:`_tool_move`) its forces, work and friction are booked, then it moves
    8. failures   (:func:`_failures`) deleted elements stop acting (their mass stays on their nodes),
                  cohesive elements tied to them are removed, every event is recorded
    9. guard      (:func:`_guard_step`) NaN/Inf, energy balance

The compiled chunk (:func:`_chunk_impl`) takes the state's arrays in seven bundles (numba namedtuples:
:class:`Nodes`, :class:`Elements`, :class:`Cohesive`, :class:`Blocks`, :class:`Tool`, :class:`Fragments`,
:class:`Books`) and hands each phase the bundles it reads.

Elements, cohesive elements and nodes are processed in blocks under ``prange`` (parallel);
each block writes only its own rows and its own scratch slot, so the loop is race free and
its cost is linear in the number of elements. The four phases with a block loop (1, 2, 3, 6) are
kernels of their own (parallel, fast-math), the others are inlined into the chunk. numba passes an
outlined block loop the variables it uses sorted by name, and under fast-math 'reassoc' LLVM regroups
sums by a rank that follows the order of that function's arguments: inlining a phase renames its
variables, reorders those arguments and changes the last bits of the results; a kernel of its own
keeps its names, and the block loops compile as when they stood in the chunk.

numba's cache does not notice edits to the functions this file calls from other files;
:mod:`solver.cachestamp` clears the solver's cached kernels when any source changed.
"""

from __future__ import annotations

import math
import types
from collections import namedtuple
from dataclasses import dataclass, field

import numba
import numpy as np
from numba import prange

from ..contact import fragment_contact_step, tool_contact
from ..threads import ThreadChoice, run_on
from .cohesive import cohesive_elastic_energy, cohesive_update
from .quad import quad_update
from .state import (E_CONTACT_BODY, E_FRAG, E_TOOL, E_DAMAGE_REMOVED, E_EXT, E_FRICTION, E_REMOVED, E_VISCOUS, P_CFL, P_DAMP, P_DELETE, P_DTCOH,
                    P_EDGEFAIL, P_EFLOOR, P_EMAX, P_ERODE, P_HGMAX, P_IGNCOH, P_INVDEL, P_MMIN, S_DT0, S_DTCRIT, S_EINIT, S_HGRUN, S_FTX, S_FTY, S_PFRIC, S_DTPREV, S_EHGMAX, S_LIMIT, S_LIMIT_ID,
                    S_NEV, S_STEPS, S_TIME)

# guard codes (guard[0])
G_OK, G_NAN, G_DT, G_HOURGLASS, G_INVERTED, G_ENERGY = 0, 1, 2, 3, 4, 5
#: steps the hourglass ratio must stay above its limit before the guard fires (contact transients pass)
HG_PERSIST = 1000


#: LLVM fast-math flags that keep IEEE NaN/Inf semantics (no 'nnan'/'ninf': the guard tests isfinite)
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}


#: the bundles the compiled chunk takes (numba namedtuples of the state's arrays, same names as on the state)
Nodes = namedtuple("Nodes", "X0 Y0 x y vx vy fx fy mass cnode fix_x fix_y vpx vpy fpx fpy fext node_active nlive "
                            "nptr nidx cptr cidx")
Nodes.__doc__ = """Nodes: reference and current positions, velocities, total forces, lumped masses, each node's own
mass-proportional damping ``cnode`` (added to the state's), prescribed dofs
(``fix_x``, ``fix_y`` with velocities ``vpx``, ``vpy``; ``fpx``, ``fpy`` their last force, for the supports'
work), external forces ``fext``, ``node_active`` and ``nlive`` (living elements holding the node), and the
node -> force-buffer CSRs of the elements (``nptr``, ``nidx``) and of the cohesive elements (``cptr``, ``cidx``)."""
Elements = namedtuple("Elements", "quads mat cphi sphi khg props stress strain eplast mhist hgd eint ehg hq alive "
                                  "fail_mode fe")
Elements.__doc__ = """Quads: connectivity, material rows and fibre angle (cos, sin), hourglass stiffnesses, the
laws' table, stresses, strains, histories (the hourglass's secant damage ``hgd`` among them), stress and
hourglass work, ``alive``, ``fail_mode`` and the per-element force buffer ``fe`` (ne, 8)."""
Cohesive = namedtuple("Cohesive", "coh coh_elems csign cL0 cprops dmg cdn cds ctn cts wcoh cdis cstate cfail_mode fc")
Cohesive.__doc__ = """Cohesive elements: nodes, tied elements, normal signs, lengths, the law, damage and
openings/tractions of the last step, work and dissipation, state, failure mode and the force buffer ``fc``."""
Blocks = namedtuple("Blocks", "eb cb nb bl_f bl_i")
Blocks.__doc__ = """The prange blocks of elements, cohesive elements and nodes (bounds ``eb``, ``cb``, ``nb``) and
their scratch rows: ``bl_f`` [dt_min, stress work, hourglass work, external work, viscous, tool work on the
body, cohesive work, kinetic energy, fragment work], ``bl_i`` [id of dt_min, failing elements, inverted,
first inverted, failing cohesive, non-finite nodes, first non-finite node]."""
Tool = namedtuple("Tool", "tool has_tool k_pen mu fcx fcy fcpx fcpy tool_out")
Tool.__doc__ = """The rigid tool: its array (moved by the loop), on/off, penalty (the lightest node's) and
friction, its forces on the nodes of this and the last step, and its sums ``tool_out``."""
Fragments = namedtuple("Fragments", "fr_on fr_edges fr_enodes fr_nodes fr_grid fr_cstart fr_cent fr_depth ffx ffy "
                                    "ffpx ffpy fr_out")
Fragments.__doc__ = """Fragment contact (:class:`solver.contact.FragmentContact`): on/off, the exposed edges,
their elements' nodes, the exposed nodes, the cell grid, penetrations, the forces of this and the last
step and the step's summary ``fr_out``."""
Books = namedtuple("Books", "params scal en guard ev ev_t")
Books.__doc__ = """Parameters (P_*), scalars (S_*), energy accounts (E_*), the guard's record, the event table
and its times."""


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _elements(nodes, elems, blocks, params, dtprev):
    """Phase 1 (prange over element blocks): stress at x^n and internal nodal forces f = A0 P b of each living
    quad into its rows of ``fe`` (total-Lagrangian one-point quad with assumed-strain hourglass control,
    Flanagan & Belytschko 1981, Belytschko & Bindeman 1993: :func:`.quad.quad_update`; the getforce of
    Belytschko, Liu & Moran 2014, box 6.1), its critical step A / (d_max c_max) (:mod:`.timestep`) and its
    failure. A failing element's forces stop acting at once and the stress work its last forces counted,
    (1/2) f^n . (x^n - x^{n-1}) (the trapezoidal rule of box 6.1's energy check), is taken back. With deletion
    on, an element whose critical step fell below params[P_ERODE] is crushed (mode 9: time-step erosion,
    LS-DYNA's ERODE/DTMIN). Each block writes its minimum step, energies and counts to its scratch rows."""
    X0 = nodes.X0
    Y0 = nodes.Y0
    x = nodes.x
    y = nodes.y
    vx = nodes.vx
    vy = nodes.vy
    quads = elems.quads
    mat = elems.mat
    cphi = elems.cphi
    sphi = elems.sphi
    khg = elems.khg
    props = elems.props
    stress = elems.stress
    strain = elems.strain
    eplast = elems.eplast
    mhist = elems.mhist
    hgd = elems.hgd
    eint = elems.eint
    ehg = elems.ehg
    hq = elems.hq
    alive = elems.alive
    fail_mode = elems.fail_mode
    fe = elems.fe
    eb = blocks.eb
    bl_f = blocks.bl_f
    bl_i = blocks.bl_i
    nbe = eb.shape[0] - 1
    check = params[P_DELETE] > 0.0
    inv_delete = params[P_INVDEL] > 0.0
    erode = params[P_ERODE] if check else 0.0
    edge_check = params[P_EDGEFAIL] > 0.0
    for b in prange(nbe):
        dtmin = 1e300
        imin = -1
        nfail = 0
        ninv = 0
        iinv = -1
        se = 0.0
        sh = 0.0
        for e in range(eb[b], eb[b + 1]):
            if alive[e] == 0:
                continue
            dte, mode, inv = quad_update(e, quads, X0, Y0, x, y, mat, cphi, sphi, khg, props, stress, strain,
                                         eplast, mhist, hgd, eint, ehg, hq, fe, check, edge_check)
            if inv == 1:
                if inv_delete:
                    mode = 9
                else:
                    ninv += 1
                    if iinv < 0:
                        iinv = e
            else:
                if mode < 0:  # an EHM element past its criterion that stays elastic: marked overloaded
                    fail_mode[e] = mode
                    mode = 0
                if mode == 0 and dte < erode:
                    mode = 9  # crushed: its critical step fell below the erosion limit
                elif dte < dtmin:
                    dtmin = dte
                    imin = e
            if mode == 0:
                se += eint[e]
                sh += ehg[e]
            else:  # a failing element's stress no longer acts, from this step on
                fail_mode[e] = mode
                nfail += 1
                # its stress work counted the trapezoid up to x^n with f^n, which now never acts:
                # take back (1/2) f^n . (x^n - x^{n-1}) so the balance stays exact
                corr = 0.0
                for k in range(4):
                    nd = quads[e, k]
                    corr += fe[e, 2 * k] * vx[nd] + fe[e, 2 * k + 1] * vy[nd]
                eint[e] += 0.5 * dtprev * corr
                for k in range(8):
                    fe[e, k] = 0.0
        bl_f[b, 0] = dtmin
        bl_f[b, 1] = se
        bl_f[b, 2] = sh
        bl_i[b, 0] = imin
        bl_i[b, 1] = nfail
        bl_i[b, 2] = ninv
        bl_i[b, 3] = iinv


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _cohesive(nodes, elems, cohesive, blocks, dtprev):
    """Phase 2 (prange over cohesive blocks): openings, damage and tractions of each cohesive element into its
    rows of ``fc`` (bilinear mixed-mode law, Camanho & Davila 2002, with the frame forces:
    :func:`.cohesive.cohesive_update`). Each block writes its failures and the work its elements hold."""
    x = nodes.x
    y = nodes.y
    vx = nodes.vx
    vy = nodes.vy
    alive = elems.alive
    coh = cohesive.coh
    coh_elems = cohesive.coh_elems
    csign = cohesive.csign
    cL0 = cohesive.cL0
    cprops = cohesive.cprops
    dmg = cohesive.dmg
    cdn = cohesive.cdn
    cds = cohesive.cds
    ctn = cohesive.ctn
    cts = cohesive.cts
    wcoh = cohesive.wcoh
    cdis = cohesive.cdis
    cstate = cohesive.cstate
    cfail_mode = cohesive.cfail_mode
    fc = cohesive.fc
    cb = blocks.cb
    bl_f = blocks.bl_f
    bl_i = blocks.bl_i
    nbc = cb.shape[0] - 1
    for b in prange(nbc):
        ncf = 0
        sw = 0.0
        for c in range(cb[b], cb[b + 1]):
            mode = cohesive_update(c, coh, coh_elems, alive, x, y, vx, vy, dtprev, csign, cL0, cprops, dmg, cdn,
                                   cds, ctn, cts, wcoh, cdis, cstate, fc)
            if mode > 0:
                cfail_mode[c] = mode
                ncf += 1
            if mode != 11 and cstate[c] != 2:
                sw += wcoh[c]
        bl_i[b, 4] = ncf
        bl_f[b, 6] = sw


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _gather(nodes, elems, cohesive, blocks):
    """Phase 3 (prange over node blocks): the assembly of box 6.1's getforce (Belytschko, Liu & Moran 2014),
    f_i = the sum of node i's entries of the element and cohesive buffers, through the node -> buffer CSRs:
    each node is summed by one block, so the assembly is race free and linear in the elements."""
    fx = nodes.fx
    fy = nodes.fy
    nptr = nodes.nptr
    nidx = nodes.nidx
    cptr = nodes.cptr
    cidx = nodes.cidx
    nb = blocks.nb
    fe_flat = elems.fe.ravel()
    fc_flat = cohesive.fc.ravel()
    nbn = nb.shape[0] - 1
    for b in prange(nbn):
        for i in range(nb[b], nb[b + 1]):
            sx = 0.0
            sy = 0.0
            for k in range(nptr[i], nptr[i + 1]):
                j = nidx[k]
                sx += fe_flat[j]
                sy += fe_flat[j + 1]
            for k in range(cptr[i], cptr[i + 1]):
                j = cidx[k]
                sx += fc_flat[j]
                sy += fc_flat[j + 1]
            fx[i] = sx
            fy[i] = sy


@numba.njit(inline="always", cache=True)
def _tool_contact(nodes, cutter, params, out, dtprev):
    """Phase 4: the rigid tool's penalty contact, a penalty per unit mass (LS-DYNA's soft constraint, k m_i),
    with Coulomb friction whose stick/slip trial is the slip the internal forces of phase 3 would make
    (:func:`solver.contact.tool_contact`): its forces go to ``fcx``, ``fcy`` (kept apart from f to book their
    work on the body in phase 6), its reaction, penetration, frictional power and forces by face to ``out``."""
    if cutter.has_tool != 0:
        fcx = cutter.fcx
        fcy = cutter.fcy
        out[:] = 0.0
        fcx[:] = 0.0
        fcy[:] = 0.0
        # k_pen is the lightest node's penalty: per unit mass it is k_pen / m_min for every node
        tool_contact(nodes.x, nodes.y, nodes.vx, nodes.vy, nodes.mass, nodes.node_active, cutter.tool,
                     cutter.k_pen / params[P_MMIN], cutter.mu, fcx, fcy, out, 1, dtprev, nodes.fx, nodes.fy, 0,
                     nodes.fix_x, nodes.fix_y)


@numba.njit(inline="always", cache=True)
def _fragment_contact(nodes, elems, frags, dtprev):
    """Phase 4b: the pieces split off by deleted elements push on each other and on the body they came from
    (node-to-segment penalty self-contact, Belytschko, Liu & Moran 2014, sec. 10.4:
    :func:`solver.contact.fragment_contact_step`) into ``ffx``, ``ffy`` (their work is booked in phase 6)."""
    if frags.fr_on != 0:
        fragment_contact_step(nodes.x, nodes.y, nodes.vx, nodes.vy, dtprev, frags.fr_edges, frags.fr_enodes,
                              frags.fr_nodes, elems.alive, nodes.node_active, frags.fr_grid, frags.fr_cstart,
                              frags.fr_cent, frags.fr_depth, frags.ffx, frags.ffy, frags.fr_out)


@numba.njit(inline="always", cache=True)
def _block_totals(blocks):
    """Phase 5a: the block rows of phases 1 and 2 summed in block order: the smallest element step and its
    element, failing elements and cohesive elements, inverted elements and the first of them, and the living
    elements' stress and hourglass work."""
    eb = blocks.eb
    cb = blocks.cb
    bl_f = blocks.bl_f
    bl_i = blocks.bl_i
    nbe = eb.shape[0] - 1
    nbc = cb.shape[0] - 1
    dt_el = 1e300
    id_el = -1
    nfail = 0
    ncfail = 0
    ninv = 0
    iinv = -1
    e_int = 0.0
    e_hg = 0.0
    for b in range(nbe):
        if bl_f[b, 0] < dt_el:
            dt_el = bl_f[b, 0]
            id_el = bl_i[b, 0]
        nfail += bl_i[b, 1]
        if bl_i[b, 2] > 0 and iinv < 0:
            iinv = bl_i[b, 3]
        ninv += bl_i[b, 2]
        e_int += bl_f[b, 1]
        e_hg += bl_f[b, 2]
    for b in range(nbc):
        ncfail += bl_i[b, 4]
    return dt_el, id_el, nfail, ncfail, ninv, iinv, e_int, e_hg


@numba.njit(inline="always", cache=True)
def _step_size(books, cutter, dt_el, id_el, dt_fixed, t, t_stop):
    """Phase 5b: dt = CFL x min(element, cohesive, contact critical steps) (:mod:`.timestep`; the central
    difference is stable for dt <= 2 / omega_max, Belytschko, Liu & Moran 2014, sec. 6.3; the contact spring
    on the lightest node: 2 sqrt(m_min / k_pen)), at most the caller's ``dt_fixed``, landing on ``t_stop``.
    Records the critical step and what limits it in ``scal``; returns (dt, dt_crit, limit, lim_id)."""
    params = books.params
    scal = books.scal
    dt_crit = dt_el
    limit = 0
    lim_id = id_el
    if params[P_IGNCOH] == 0.0 and params[P_DTCOH] < dt_crit:
        dt_crit = params[P_DTCOH]
        limit = 1
        lim_id = -1
    if cutter.has_tool != 0 and cutter.k_pen > 0.0:
        dtc = 2.0 * math.sqrt(params[P_MMIN] / cutter.k_pen)
        if dtc < dt_crit:
            dt_crit = dtc
            limit = 2
            lim_id = -1
    dt = params[P_CFL] * dt_crit
    if dt_fixed > 0.0 and dt_fixed < dt:
        dt = dt_fixed
    if t + dt > t_stop and t_stop > t:  # land on the requested time (a sample time of run())
        dt = t_stop - t
    scal[S_DTCRIT] = dt_crit
    scal[S_LIMIT] = limit
    scal[S_LIMIT_ID] = lim_id
    return dt, dt_crit, limit, lim_id


@numba.njit(inline="always", cache=True)
def _guard_configuration(elems, books, ninv, iinv, e_int, e_hg, dt, dt_crit, limit, lim_id, step, t):
    """Phase 5c: the guard's checks on the configuration x^n (:mod:`.guard`): an inverted element that is not
    deleted, the stable step below 1/100 of the initial one, hourglass energy above params[P_HGMAX] of the
    largest element strain energy so far for more than HG_PERSIST steps. Returns the guard code (G_OK: go on)."""
    params = books.params
    scal = books.scal
    guard = books.guard
    if ninv > 0:
        guard[0] = G_INVERTED
        guard[1] = iinv
        guard[2] = step
        guard[3] = t
        guard[4] = ninv
        guard[5] = dt
        return G_INVERTED
    if not (params[P_CFL] * dt_crit >= 0.01 * scal[S_DT0]) and dt_crit < 1e299:
        guard[0] = G_DT
        guard[1] = lim_id
        guard[2] = step
        guard[3] = t
        guard[4] = params[P_CFL] * dt_crit / scal[S_DT0]
        guard[5] = limit
        return G_DT
    # hourglass energy against the largest element strain energy so far (stress work + hourglass)
    e_tot = e_int + e_hg
    if e_tot > scal[S_EHGMAX]:
        scal[S_EHGMAX] = e_tot
    if scal[S_EHGMAX] > params[P_EFLOOR] and e_hg > params[P_HGMAX] * scal[S_EHGMAX]:
        scal[S_HGRUN] += 1.0  # consecutive steps above the limit
    else:
        scal[S_HGRUN] = 0.0
    if scal[S_HGRUN] > HG_PERSIST:
        alive = elems.alive
        ehg = elems.ehg
        ib = -1
        vb = -1.0
        for e in range(alive.shape[0]):
            if alive[e] != 0 and ehg[e] > vb:
                vb = ehg[e]
                ib = e
        guard[0] = G_HOURGLASS
        guard[1] = ib
        guard[2] = step
        guard[3] = t
        guard[4] = e_hg / scal[S_EHGMAX]
        guard[5] = dt
        return G_HOURGLASS
    return G_OK


@numba.njit(parallel=True, cache=True, fastmath=FASTMATH)
def _update(nodes, cutter, frags, blocks, books, dt, dtprev):
    """Phase 6 (prange over node blocks): the central-difference update with a variable step (Belytschko, Liu
    & Moran 2014, box 6.1), v^{n+1/2} = v^{n-1/2} + (dt_prev + dt)/2 (f^n/m - c v^{n-1/2}),
    x^{n+1} = x^n + dt v^{n+1/2} (c: the state's damping plus the node's own), with the tool's, the fragments'
    and the external forces added to f^n;
    prescribed dofs take their velocity. Books beside it, each over [x^{n-1}, x^n] by the trapezoidal rule of
    box 6.1's energy check: the tool's and the fragments' work on the body, the external forces' and the
    supports' work, and the damping's dissipation c m v_mid^2 dt. A non-finite update is not written.
    Returns (non-finite nodes, the first of them)."""
    x = nodes.x
    y = nodes.y
    vx = nodes.vx
    vy = nodes.vy
    fx = nodes.fx
    fy = nodes.fy
    mass = nodes.mass
    fix_x = nodes.fix_x
    fix_y = nodes.fix_y
    vpx = nodes.vpx
    vpy = nodes.vpy
    fpx = nodes.fpx
    fpy = nodes.fpy
    fext = nodes.fext
    cnode = nodes.cnode
    has_tool = cutter.has_tool
    fcx = cutter.fcx
    fcy = cutter.fcy
    fcpx = cutter.fcpx
    fcpy = cutter.fcpy
    fr_on = frags.fr_on
    ffx = frags.ffx
    ffy = frags.ffy
    ffpx = frags.ffpx
    ffpy = frags.ffpy
    nb = blocks.nb
    bl_f = blocks.bl_f
    bl_i = blocks.bl_i
    scal = books.scal
    en = books.en
    nbn = nb.shape[0] - 1
    has_ext = fext.shape[1] == x.shape[0]
    cstate = books.params[P_DAMP]
    dth = 0.5 * (scal[S_DTPREV] + dt)
    for b in prange(nbn):
        wext = 0.0
        wvis = 0.0
        wcon = 0.0
        wfr = 0.0
        ke = 0.0
        nnan = 0
        inan = -1
        for i in range(nb[b], nb[b + 1]):
            m = mass[i]
            cdamp = cstate + cnode[i]
            if has_tool != 0:
                # work of the tool's forces on the body over [x^{n-1}, x^n], trapezoidal (the rule
                # the central-difference kinetic energy obeys)
                wcon += 0.5 * ((fcpx[i] + fcx[i]) * vx[i] + (fcpy[i] + fcy[i]) * vy[i]) * dtprev
                fcpx[i] = fcx[i]
                fcpy[i] = fcy[i]
                fx[i] += fcx[i]
                fy[i] += fcy[i]
            if fr_on != 0:
                # the fragment forces' work on the body, trapezoidal (minus the springs' energy)
                wfr += 0.5 * ((ffpx[i] + ffx[i]) * vx[i] + (ffpy[i] + ffy[i]) * vy[i]) * dtprev
                ffpx[i] = ffx[i]
                ffpy[i] = ffy[i]
                fx[i] += ffx[i]
                fy[i] += ffy[i]
            if has_ext:
                # external nodal forces held over the chunk: their work, trapezoidal, is external
                wext += 0.5 * ((fext[2, i] + fext[0, i]) * vx[i] + (fext[3, i] + fext[1, i]) * vy[i]) * dtprev
                fext[2, i] = fext[0, i]
                fext[3, i] = fext[1, i]
                fx[i] += fext[0, i]
                fy[i] += fext[1, i]
            if fix_x[i] != 0:
                wext -= 0.5 * (fpx[i] + fx[i]) * vx[i] * dtprev  # the support's work, trapezoidal
                fpx[i] = fx[i]
                vxn = vpx[i]
            elif m > 0.0:
                vxn = vx[i] + dth * (fx[i] / m - cdamp * vx[i])
                if cdamp > 0.0:
                    vm = 0.5 * (vx[i] + vxn)
                    wvis += cdamp * m * vm * vm * dt
            else:
                vxn = vx[i]
            if fix_y[i] != 0:
                wext -= 0.5 * (fpy[i] + fy[i]) * vy[i] * dtprev
                fpy[i] = fy[i]
                vyn = vpy[i]
            elif m > 0.0:
                vyn = vy[i] + dth * (fy[i] / m - cdamp * vy[i])
                if cdamp > 0.0:
                    vm = 0.5 * (vy[i] + vyn)
                    wvis += cdamp * m * vm * vm * dt
            else:
                vyn = vy[i]
            xn = x[i] + dt * vxn
            yn = y[i] + dt * vyn
            if not (math.isfinite(xn) and math.isfinite(yn) and math.isfinite(vxn) and math.isfinite(vyn)):
                nnan += 1
                if inan < 0:
                    inan = i
                continue
            ke += 0.5 * m * (vxn * vxn + vyn * vyn)
            vx[i] = vxn
            vy[i] = vyn
            x[i] = xn
            y[i] = yn
        bl_f[b, 3] = wext
        bl_f[b, 4] = wvis
        bl_f[b, 5] = wcon
        bl_f[b, 7] = ke
        bl_f[b, 8] = wfr
        bl_i[b, 5] = nnan
        bl_i[b, 6] = inan
    nnan = 0
    inan = -1
    for b in range(nbn):
        en[E_EXT] += bl_f[b, 3]
        en[E_VISCOUS] += bl_f[b, 4]
        en[E_CONTACT_BODY] += bl_f[b, 5]
        en[E_FRAG] += bl_f[b, 8]
        if bl_i[b, 5] > 0 and inan < 0:
            inan = bl_i[b, 6]
        nnan += bl_i[b, 5]
    return nnan, inan


@numba.njit(inline="always", cache=True)
def _tool_move(cutter, books, out, dt, dtprev):
    """Phase 7: the tool's force sums, deepest penetration and friction; its work on the body and the friction's
    dissipation over [t^{n-1}, t^n] by the trapezoidal rule (as the body side, box 6.1's energy check of
    Belytschko, Liu & Moran 2014); then the rigid tool moves, x_tool += v_tool dt."""
    if cutter.has_tool != 0:
        tool = cutter.tool
        tool_out = cutter.tool_out
        scal = books.scal
        en = books.en
        tool_out[0] += out[0]
        tool_out[1] += out[1]
        for j in range(4, 10):  # the same by face of the tool
            tool_out[j] += out[j]
        if out[2] > tool_out[2]:
            tool_out[2] = out[2]
        # tool work and friction over [t^{n-1}, t^n], trapezoidal like the body side
        tool_out[3] += 0.5 * (out[3] + scal[S_PFRIC]) * dtprev
        en[E_FRICTION] += 0.5 * (out[3] + scal[S_PFRIC]) * dtprev
        en[E_TOOL] -= 0.5 * ((out[0] + scal[S_FTX]) * tool[2] + (out[1] + scal[S_FTY]) * tool[3]) * dtprev
        scal[S_FTX] = out[0]
        scal[S_FTY] = out[1]
        scal[S_PFRIC] = out[3]
        tool[0] += tool[2] * dt
        tool[1] += tool[3] * dt


@numba.njit(inline="always", cache=True)
def _record_event(scal, ev, ev_t, kind, idx, mat, mode, step, t):
    """One row of the event table (kind 0 an element, 1 a cohesive element; its index, material (-1 for a
    cohesive element), failure mode, step) and its time, while the table has room."""
    k = int(scal[S_NEV])
    if k < ev.shape[0]:
        ev[k, 0] = kind
        ev[k, 1] = idx
        ev[k, 2] = mat
        ev[k, 3] = mode
        ev[k, 4] = step
        ev_t[k] = t
        scal[S_NEV] = k + 1


@numba.njit(inline="always", cache=True)
def _failures(nodes, elems, cohesive, books, nfail, ncfail, step, t):
    """Phase 8: failed elements are deleted (their stress stops acting, their mass stays on their nodes, a node
    no living element holds stops touching the tool); the stress and hourglass work they hold goes to
    E_REMOVED. Cohesive elements: a fully damaged one is debonded (mode 10), one tied to a deleted element is
    removed (mode 11: its free energy to E_REMOVED, its dissipation to E_DAMAGE_REMOVED; the paper's matrix
    failure deleting the linked cohesive elements). Every event goes to the event table."""
    scal = books.scal
    en = books.en
    ev = books.ev
    ev_t = books.ev_t
    if nfail > 0:
        node_active = nodes.node_active
        nlive = nodes.nlive
        quads = elems.quads
        mat = elems.mat
        stress = elems.stress
        eint = elems.eint
        ehg = elems.ehg
        alive = elems.alive
        fail_mode = elems.fail_mode
        fe = elems.fe
        for e in range(quads.shape[0]):
            if alive[e] != 0 and fail_mode[e] > 0:
                alive[e] = 0
                en[E_REMOVED] += eint[e] + ehg[e]
                for k in range(8):
                    fe[e, k] = 0.0
                for k in range(4):
                    stress[e, k] = 0.0
                    nd = quads[e, k]
                    nlive[nd] -= 1
                    if nlive[nd] <= 0:
                        node_active[nd] = 0
                _record_event(scal, ev, ev_t, 0, e, mat[e], fail_mode[e], step, t)
    if ncfail > 0:
        cL0 = cohesive.cL0
        cprops = cohesive.cprops
        dmg = cohesive.dmg
        cdn = cohesive.cdn
        cds = cohesive.cds
        ctn = cohesive.ctn
        wcoh = cohesive.wcoh
        cstate = cohesive.cstate
        cfail_mode = cohesive.cfail_mode
        fc = cohesive.fc
        for c in range(cfail_mode.shape[0]):
            mode = cfail_mode[c]
            if mode == 0 or cstate[c] == 2 or (mode == 10 and cstate[c] == 1):
                continue
            el = 0.5 * cL0[c] * cohesive_elastic_energy(c, cprops, dmg, cdn, cds, ctn)
            if mode == 11:
                cstate[c] = 2
                en[E_REMOVED] += el
                en[E_DAMAGE_REMOVED] += wcoh[c] - el
                for k in range(8):
                    fc[c, k] = 0.0
            else:
                cstate[c] = 1
            _record_event(scal, ev, ev_t, 1, c, -1, mode, step, t)


@numba.njit(inline="always", cache=True)
def _guard_step(blocks, books, nnan, inan, e_int, e_hg, id_el, step, t, dt):
    """Phase 9: the guard on the step just taken (:mod:`.guard`): a non-finite position or velocity (never
    written to the state), then the energy balance of the body side, box 6.1's energy check (Belytschko, Liu
    & Moran 2014): |initial + external - held| <= params[P_EMAX] max(|initial| + |external|, stress +
    hourglass + kinetic energy) (the scale of the reported energy error), held = stress, hourglass, kinetic,
    cohesive, removed and viscous energy; an unstable step creates energy out of nothing. Returns the guard
    code (G_OK: go on)."""
    params = books.params
    scal = books.scal
    en = books.en
    guard = books.guard
    bl_f = blocks.bl_f
    nbc = blocks.cb.shape[0] - 1
    nbn = blocks.nb.shape[0] - 1
    if nnan > 0:
        guard[0] = G_NAN
        guard[1] = inan
        guard[2] = step
        guard[3] = t
        guard[4] = nnan
        guard[5] = dt
        return G_NAN
    kinetic = 0.0
    for b in range(nbn):
        kinetic += bl_f[b, 7]
    held = e_int + e_hg + kinetic + en[E_REMOVED] + en[E_DAMAGE_REMOVED] + en[E_VISCOUS]
    for b in range(nbc):
        held += bl_f[b, 6]
    given = scal[S_EINIT] + en[E_EXT] + en[E_CONTACT_BODY] + en[E_FRAG]
    # the scale of the reported energy error (solver.fem.energy): energies that cannot be negative, so that an
    # element that gave back more than it took (booked negative when it is deleted) cannot shrink it
    scale = max(abs(scal[S_EINIT]) + abs(en[E_EXT]) + abs(en[E_CONTACT_BODY]) + abs(en[E_FRAG]), e_int + e_hg + kinetic)
    if step > 10 and scale > params[P_EFLOOR] and abs(given - held) > params[P_EMAX] * scale:
        guard[0] = G_ENERGY
        guard[1] = id_el
        guard[2] = step
        guard[3] = t
        guard[4] = abs(given - held) / scale
        guard[5] = dt
        return G_ENERGY
    return G_OK


def _chunk_impl(n_steps, dt_fixed, t_stop, nodes, elems, cohesive, blocks, cutter, frags, books):
    """Run up to n_steps steps (module docstring): one call per phase; stop early at t >= t_stop or when the
    guard fires. The arrays come in bundles (:class:`Nodes`, :class:`Elements`, :class:`Cohesive`,
    :class:`Blocks`, :class:`Tool`, :class:`Fragments`, :class:`Books`).

    Returns the number of steps done. guard[:] = (code, id, step, time, value, dt, extra, 0).
    """
    params = books.params
    scal = books.scal
    out = np.zeros(10)  # the tool's sums of the step (phase 4, booked in phase 7)
    done = 0
    for it in range(n_steps):
        t = scal[S_TIME]
        step = int(scal[S_STEPS])
        dtprev = scal[S_DTPREV]
        _elements(nodes, elems, blocks, params, dtprev)  # 1
        _cohesive(nodes, elems, cohesive, blocks, dtprev)  # 2
        _gather(nodes, elems, cohesive, blocks)  # 3
        _tool_contact(nodes, cutter, params, out, dtprev)  # 4
        _fragment_contact(nodes, elems, frags, dtprev)  # 4b
        dt_el, id_el, nfail, ncfail, ninv, iinv, e_int, e_hg = _block_totals(blocks)  # 5
        dt, dt_crit, limit, lim_id = _step_size(books, cutter, dt_el, id_el, dt_fixed, t, t_stop)
        if _guard_configuration(elems, books, ninv, iinv, e_int, e_hg, dt, dt_crit, limit, lim_id, step, t) != G_OK:
            break
        nnan, inan = _update(nodes, cutter, frags, blocks, books, dt, dtprev)  # 6
        _tool_move(cutter, books, out, dt, dtprev)  # 7
        scal[S_TIME] = t + dt
        scal[S_STEPS] = step + 1
        scal[S_DTPREV] = dt
        done += 1
        _failures(nodes, elems, cohesive, books, nfail, ncfail, step, t)  # 8
        if _guard_step(blocks, books, nnan, inan, e_int, e_hg, id_el, step, t, dt) != G_OK:  # 9
            break
        if scal[S_TIME] >= t_stop:
            break
    return done


def _compiled(name: str, parallel: bool):
    """A compiled copy of :func:`_chunk_impl` under its own name (so numba caches each apart)."""
    fn = types.FunctionType(_chunk_impl.__code__, _chunk_impl.__globals__, name, _chunk_impl.__defaults__,
                            _chunk_impl.__closure__)
    fn.__qualname__ = name
    fn.__doc__ = _chunk_impl.__doc__
    return numba.njit(parallel=parallel, cache=True, fastmath=FASTMATH)(fn)


#: the chunk on numba's threads (its phases' prange over blocks). A serial build of the block loops
#: (parallel=False) measured 35-50 % slower per element even on one thread (numba's parallel build lets
#: LLVM assume the outlined block loop's arrays do not alias), so one thread runs this same build with
#: set_num_threads(1).
_chunk = _compiled("_chunk_parallel", True)


@dataclass
class StepRecord:
    """What :func:`advance` returns: steps done, time reached, the last step and the guard's finding."""

    steps: int
    time: float
    dt: float
    status: str = "ok"  # ok | unstable
    finding: dict | None = None  # the stability guard's diagnosis (solver.fem.guard), None when ok
    dt_limit: str = ""
    extra: dict = field(default_factory=dict)


def _bundle(kind, s, **given):
    """The bundle ``kind`` (a namedtuple) of the state's arrays of the same names; ``given`` sets the others."""
    return kind(*[given[f] if f in given else getattr(s, f) for f in kind._fields])


def bundles(s, k_pen, mu) -> tuple:
    """The seven bundles of :func:`_chunk_impl` over the state ``s``'s arrays, with the tool's penalty
    ``k_pen`` and friction ``mu``."""
    return (_bundle(Nodes, s), _bundle(Elements, s), _bundle(Cohesive, s), _bundle(Blocks, s),
            _bundle(Tool, s, has_tool=np.int64(s.has_tool), k_pen=float(k_pen), mu=float(mu)),
            _bundle(Fragments, s, fr_on=np.int64(s.fr_on)), _bundle(Books, s))


def _call_chunk(s, n_steps, dt_fixed, t_stop, k_pen, mu):
    return _chunk(n_steps, dt_fixed, t_stop, *bundles(s, k_pen, mu))


def step_record(state, steps: int) -> StepRecord:
    """The :class:`StepRecord` of a chunk of ``steps`` steps that ended at the state's time: its last step,
    what limits the step and, when the guard fired, its diagnosis."""
    from .guard import diagnosis
    from .timestep import LIMITS, describe_limit

    lim = describe_limit(state, LIMITS[int(state.scal[S_LIMIT])], int(state.scal[S_LIMIT_ID]))
    rec = StepRecord(int(steps), state.time, float(state.scal[S_DTPREV]), dt_limit=lim)
    if state.guard[0] != G_OK:
        rec.status = "unstable"
        rec.finding = diagnosis(state)
    return rec


def advance(state, n_steps: int, dt: float | None = None, k_pen: float | None = None, mu: float | None = None,
            t_stop: float = math.inf, threads: int | None = None) -> StepRecord:
    """Run ``n_steps`` explicit steps in compiled code (fewer if ``t_stop`` or the guard stops it).

    dt: the largest step [s] (e.g. from :func:`stable_dt`); every step takes
        min(dt, CFL x the critical step of the current configuration), so elements that distort
        within a chunk shrink the step at once. None or 0: always CFL x the critical step.
    k_pen: tool penalty stiffness [N/m per m width]; mu: Coulomb friction (both only used when
        the state has a tool; None keeps the state's last values, initially 0).
    t_stop: stop once the time reaches it. threads: numba threads for this call (default: the
        state's :class:`solver.threads.ThreadChoice`, which times its chunks on one and on all threads
        and runs on the faster; the results do not depend on it).
    Returns a :class:`StepRecord`; ``status`` is ``unstable`` and ``finding`` the diagnosis
    when the stability guard fired (the state then holds the last finite configuration).
    A state that is already unstable is not advanced.
    """
    from .guard import diagnosis

    if state.guard[0] != G_OK:
        return StepRecord(0, state.time, float(state.scal[S_DTPREV]), "unstable", diagnosis(state))
    if k_pen is not None:
        state.k_pen = float(k_pen)
    if mu is not None:
        state.mu = float(mu)
    if state.has_tool and state.k_pen <= 0:
        raise ValueError(f"k_pen = {state.k_pen}: a state with a tool needs a positive contact penalty stiffness")
    n_steps = int(n_steps)
    if n_steps < 0:
        raise ValueError(f"n_steps = {n_steps}: must be >= 0")
    if state.e_initial is None:
        from .energy import energies
        e = energies(state)
        state.e_initial = e["kinetic"] + e["internal"] + e["hourglass"]
        state.scal[S_EINIT] = state.e_initial
    def call():
        return _call_chunk(state, n_steps, float(dt or 0.0), float(t_stop), state.k_pen, state.mu)

    done = thread_choice(state).run(call) if threads is None else run_on(threads, call)
    return step_record(state, done)


def thread_choice(state) -> ThreadChoice:
    """The state's :class:`solver.threads.ThreadChoice` (made at its first chunk)."""
    choice = getattr(state, "thread_choice", None)
    if choice is None:
        choice = state.thread_choice = ThreadChoice()
    return choice


def run(state, t_end: float, progress=None, chunk_steps: int = 2000, n_samples: int = 200, dt: float | None = None,
        k_pen: float | None = None, mu: float | None = None, max_steps: int = 100_000_000) -> dict:
    """Advance to ``t_end`` sampling histories at ``n_samples`` equally spaced times.

    Between chunks (at most ``chunk_steps`` steps, always ending on a sample time) it calls
    ``progress(fraction, message)``; a ``False`` answer cancels. Returns a dict: ``status``
    (ok | unstable | cancelled | failed), ``finding``, ``steps``, and ``series``:
    time [s], Fx, Fy (mean tool force over the sample interval [N/m]), dt [s] and every
    energy of :func:`solver.fem.energy.energies` [J/m].
    """
    from .energy import energies

    series: dict[str, list] = {"time": [], "Fx": [], "Fy": [], "dt": []}
    status, finding, steps = "ok", None, 0
    t0 = state.time
    for k in range(1, n_samples + 1):
        t_target = t0 + (t_end - t0) * k / n_samples
        s0, fx0, fy0 = state.steps, state.tool_out[0], state.tool_out[1]
        while state.time < t_target * (1 - 1e-12):
            rec = advance(state, chunk_steps, dt, k_pen, mu, t_stop=t_target)
            steps += rec.steps
            if rec.status != "ok":
                status, finding = rec.status, rec.finding
                break
            if steps > max_steps:
                status = "failed"
                finding = {"check": "max_steps", "what": f"more than {max_steps} steps", "time_s": state.time}
                break
        n = max(state.steps - s0, 1)
        series["time"].append(state.time)
        series["Fx"].append((state.tool_out[0] - fx0) / n)
        series["Fy"].append((state.tool_out[1] - fy0) / n)
        series["dt"].append(float(state.scal[S_DTPREV]))
        for key, v in energies(state).items():
            series.setdefault(key, []).append(v)
        if status != "ok":
            break
        if progress is not None and progress(k / n_samples, f"t = {state.time:.4g} s, step {state.steps}") is False:
            status = "cancelled"
            break
    return {"status": status, "finding": finding, "steps": steps,
            "series": {k: np.asarray(v) for k, v in series.items()}}
