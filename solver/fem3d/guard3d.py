"""The 3D engine's stability guard: which check fired, where, when, and what to change.

The checks run inside the compiled chunk (:mod:`.loop`) and stop it at once, as the 2D engine's
(:mod:`solver.fem.guard`, same codes and names):

* ``nan``         a position or velocity became NaN/Inf (every step; the offending update is not written:
                  the state keeps the last finite values); where: the first such node;
* ``inverted``    an element with det F <= 0 that is not deleted (every step; ``delete_inverted`` deletes it
                  as failure mode 9 instead); where: the first such element;
* ``dt_collapse`` (every GUARD_EVERY steps) an element's current critical step, its reference one scaled by
                  |b0| / |F^-T b0| (the Flanagan-Belytschko bound's dependence on the element's gradient),
                  times CFL fell below 1/100 of the initial step: a crushed element; where: that element;
* ``hourglass``   (every GUARD_EVERY steps) hourglass energy above ``hourglass_ratio_max`` (10 %) of the
                  largest element strain energy so far for more than 1000 steps, once that energy exceeds a
                  uniform strain of 1e-3 over the mesh; where: the element holding the most hourglass energy;
* ``energy``      (every GUARD_EVERY steps) the energy balance's residual above ``energy_error_max`` (50 %)
                  of the energy in play: energy created by an unstable step; where: the fastest node.

:func:`diagnosis` turns the chunk's ``guard`` record (code, id, step, time, value, dt) into a dict: the
check, what happened, where (element or node id, its material row, its position [m]), when (time [s],
step) and what to change.
"""

from __future__ import annotations

import numpy as np

from .loop import G_DT, G_ENERGY, G_HOURGLASS, G_INVERTED, G_NAN, P_DELETE, P_HGMAX, P_INVDEL

CHECKS = {G_NAN: "nan", G_DT: "dt_collapse", G_HOURGLASS: "hourglass", G_INVERTED: "inverted", G_ENERGY: "energy"}


def _element_where(state, e: int) -> dict:
    if e < 0 or e >= state.hexes.shape[0]:
        return {"element": None}
    return {"element": int(e), "material_row": int(state.mat[e]),
            "position_m": [float(c) for c in state.x[:, state.hexes[e]].mean(axis=1)]}


def _node_where(state, i: int) -> dict:
    if i < 0 or i >= state.x.shape[1]:
        return {"node": None}
    k0, k1 = int(state.nptr[i]), int(state.nptr[i + 1])
    e = int(state.nidx[k0]) // 24 if k1 > k0 else None
    return {"node": int(i), "element": e, "position_m": [float(c) for c in state.x[:, i]]}


def diagnosis(state) -> dict | None:
    """The guard's finding (module docstring), or None when it did not fire."""
    g = state.guard
    code = int(g[0])
    if code == 0:
        return None
    ident, step, t, val, dt = int(g[1]), int(g[2]), float(g[3]), float(g[4]), float(g[5])
    d = {"check": CHECKS.get(code, str(code)), "step": step, "time_s": t, "dt_s": dt, "cfl": float(state.cfl)}
    deletion = state.gpar[P_DELETE] > 0.0
    if code == G_NAN:
        d.update(_node_where(state, ident), n_nonfinite=int(val))
        d["what"] = f"{int(val)} dof(s) got a NaN/Inf position or velocity (first: node {ident})"
        d["change"] = ("lower the CFL (<= 0.9); check a cohesive penalty against its step limit and the "
                       "applied loads")
    elif code == G_INVERTED:
        d.update(_element_where(state, ident), n_inverted=int(val))
        d["what"] = f"element {ident} turned inside out (det F <= 0); {int(val)} inverted in all"
        d["change"] = ("lower the CFL, refine the mesh"
                       + ("" if state.gpar[P_INVDEL] > 0 else ", or delete inverted elements (delete_inverted)"))
    elif code == G_DT:
        d.update(_element_where(state, ident), dt_ratio=val)
        d["what"] = (f"element {ident}'s critical step fell to {val:.3g} x the initial step (below 1/100): "
                     "it is being crushed")
        d["change"] = ("refine the mesh near the load, lower the loading rate"
                       + ("" if deletion else ", or enable element deletion"))
    elif code == G_HOURGLASS:
        d.update(_element_where(state, ident), hourglass_ratio=val)
        d["what"] = (f"hourglass energy is {100 * val:.1f} % of the (largest) element strain energy (limit "
                     f"{100 * float(state.gpar[P_HGMAX]):.0f} %); largest in element {ident}")
        d["change"] = "refine the mesh (more elements across a bending strip) or lower the load rate"
    elif code == G_ENERGY:
        d.update(_node_where(state, ident), residual_fraction=val)
        d["what"] = (f"the energy balance broke down: residual {100 * val:.0f} % of the energy in play (energy "
                     f"created by the time integration); fastest node {ident}")
        d["change"] = "lower the CFL (<= 0.9); keep a cohesive penalty's step limit"
    d["where"] = {k: d[k] for k in ("element", "node", "material_row", "position_m") if k in d}
    d["when"] = {"time_s": t, "step": step}
    return d


def failure_report(state) -> dict:
    """The deleted elements by failure mode (the 2D MODE_NAMES) and the overloaded EHM elements: counts,
    first time."""
    from ..fem.materials import MODE_NAMES

    out = {}
    fm = state.fail_mode
    for mode in np.unique(fm[fm != 0]):
        sel = fm == mode
        name = MODE_NAMES[abs(int(mode))] + (" (overloaded, kept)" if mode < 0 else "")
        times = state.fail_time[sel, 0]
        times = times[times >= 0]
        out[name] = {"count": int(sel.sum()), "first_time_s": float(times.min()) if times.size else None}
    return out
