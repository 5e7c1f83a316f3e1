"""The stability guard's diagnosis: which check fired, where, when, and what to change.

The checks run inside the compiled loop (:mod:`.loop`, step 5 and 9) and stop it at once:

* ``nan``        a position or velocity became NaN/Inf (the offending update is not written:
                 the state keeps the last finite values);
* ``dt_collapse`` the stable step fell below 1/100 of the initial step (a crushed element);
* ``hourglass``  hourglass energy above ``hourglass_ratio_max`` (default 10 %) of the element
                 strain energy (stress work + hourglass; its largest value so far, so that an
                 elastic oscillation passing through zero strain is not a finding) for more than
                 1000 consecutive steps (a contact transient on a few elements passes), once that
                 energy exceeds a uniform strain of 1e-3 over the whole mesh. With the
                 assumed-strain stabilization the hourglass modes hold real bending energy: 1/n^2
                 of it with n elements across a bending strip, so the check asks for at least 4
                 elements across a strip in sustained bending;
* ``inverted``   an element with zero or negative area (or Jacobian) that is not deleted;
* ``energy``     (beyond the issue's four) the energy balance's residual above
                 ``energy_error_max`` (50 %) of the energy in play: an unstable step creating
                 energy, even when element deletion keeps the numbers finite.

:func:`diagnosis` turns the loop's ``guard`` record into the dict a Result carries.
"""

from __future__ import annotations

from ..mesh import MATERIAL_NAMES
from .state import P_DELETE
from .timestep import LIMITS

CHECKS = {1: "nan", 2: "dt_collapse", 3: "hourglass", 4: "inverted", 5: "energy"}


def _element(state, e):
    if e is None or e < 0 or e >= state.quads.shape[0]:
        return None, None
    return int(e), MATERIAL_NAMES[int(state.mat[e])]


def _node_element(state, node):
    """An element holding ``node`` (the first in the node -> element map)."""
    if node < 0:
        return None
    k0 = int(state.nptr[node])
    if k0 >= int(state.nptr[node + 1]):
        return None
    return int(state.nidx[k0]) // 8


def diagnosis(state) -> dict | None:
    g = state.guard
    code = int(g[0])
    if code == 0:
        return None
    ident, step, t, val, extra = int(g[1]), int(g[2]), float(g[3]), float(g[4]), float(g[5])
    cfl = float(state.params[0])
    d = {"check": CHECKS.get(code, str(code)), "step": step, "time_s": t, "cfl": cfl,
         "dt_initial_s": float(state.dt_initial)}
    if code == 1:
        e, mat = _element(state, _node_element(state, ident))
        d.update(node=ident, element=e, material=mat, n_nonfinite=int(val), dt_s=extra,
                 what=f"{int(val)} node(s) got a NaN/Inf position or velocity (first: node {ident}"
                      + (f", in element {e} ({mat})" if e is not None else "") + ")",
                 change="lower numerics.cfl (<= 0.9); check the cohesive penalty against its time-step limit "
                        "(materials.interface.penalty_N_mm3) and the contact stiffness factor")
    elif code == 2:
        kind = LIMITS[int(extra)] if 0 <= int(extra) < len(LIMITS) else "element"
        e, mat = _element(state, ident) if kind == "element" else (None, None)
        d.update(element=e, material=mat, limited_by=kind, dt_ratio=val,
                 what=f"stable step fell to {val:.3g} x the initial step (below 1/100), limited by {kind}"
                      + (f" element {e} ({mat})" if e is not None else ""),
                 change=("the element is being crushed: enable element deletion (physics.element_deletion, which "
                         "erodes crushed elements), refine the mesh near the tool, or lower the cutting speed / speed scaling"
                         if state.params[P_DELETE] == 0.0 else
                         "the element was crushed faster than erosion could remove it (element deletion is on): lower "
                         "numerics.cfl or numerics.speed_scaling, or refine the mesh near the tool"))
    elif code in (3, 4, 5):  # an element's finding
        e, mat = _element(state, ident)
        d.update(element=e, material=mat)
        if code == 3:
            d.update(hourglass_ratio=val, dt_s=extra,
                     what=f"hourglass energy is {100 * val:.1f} % of the (largest) element strain energy "
                          f"(limit {100 * float(state.params[6]):.0f} %); largest in element {e} ({mat})",
                     change="refine the mesh (more elements across the fibre: numerics.elements_across_fibre) "
                            "or lower the load rate")
        elif code == 4:
            d.update(n_inverted=int(val), dt_s=extra,
                     what=f"element {e} ({mat}) turned inside out (area or Jacobian <= 0); {int(val)} inverted in all",
                     change=("lower numerics.cfl, refine the mesh" + (", or enable element deletion" if state.params[P_DELETE] == 0.0 else "")
                             + "; an unstable step (CFL above 1 or a stiff penalty without its step limit) also does this"))
        else:
            d.update(residual_fraction=val, dt_s=extra,
                     what=f"the energy balance broke down: residual {100 * val:.0f} % of the energy in play "
                          f"(energy created by the time integration); the step is limited by element {e} ({mat})",
                     change="lower numerics.cfl (<= 0.9); keep the cohesive penalty's time-step limit; lower "
                            "numerics.contact_stiffness_factor")
    return d
