"""The energy balance of a run (docs/model.md, "Numerics"), evaluated at the last completed step n.

    external  = work of the tool on the workpiece (minus the force on the tool . tool velocity)
                + work of the supports of prescribed velocities (reaction . prescribed velocity)
    internal  = stress work of the living elements (elastic + plastic; trapezoidal in S:dE)
                + recoverable energy of the cohesive elements
    kinetic   = 1/2 m v^2 with v^n = v^{n+1/2} - dt/2 f^n/m (integer-step velocity)
    hourglass = assumed-strain hourglass energy of the living elements (stored, elastic)
    contact   = energy in the tool's penalty springs (tool work - contact work on the body - friction)
    fragment_contact = energy in the fragment-contact penalty springs (minus their work on the body)
    damage    = energy dissipated by cohesive softening, (1/2) K (<dn>^2 + ds^2) dd summed as the
                damage grows (solver.fem.cohesive.cohesive_update)
    removed   = energy held by elements (and cohesive elements) when they were deleted
    friction  = tool friction; viscous = mass-proportional damping (quasi-static runs)

    initial   = kinetic + internal + hourglass when the first step was taken (initial velocities)
    residual  = initial + external - (internal + kinetic + hourglass + damage + removed + friction + viscous)
    energy_error = |residual| / max(|external| + |initial|, internal + kinetic + hourglass, tiny)

    cohesive_unaccounted = work of the cohesive forces - their free energy - their dissipation: not a
                term of the balance but the part of its residual the cohesive elements make (the turn
                of the frame of elements with a fully damaged point, whose frame forces are left out,
                and a debonded point's penalty switching on as its faces come to face each other
                again; solver.fem.cohesive). Damage is booked from the law's own dissipation, not
                as work - free energy, which would hide this part.
"""

from __future__ import annotations

import numba

from .cohesive import cohesive_elastic_energy
from .state import E_TOOL, E_CONTACT_BODY, E_FRAG, E_DAMAGE_REMOVED, E_EXT, E_FRICTION, E_REMOVED, E_VISCOUS, S_DTPREV


@numba.njit(cache=True)
def _sums(alive, eint, ehg, cstate, cL0, cprops, dmg, cdn, cds, ctn, wcoh, mass, vx, vy, fx, fy, fix_x, fix_y, dt):
    e_int = 0.0
    e_hg = 0.0
    for e in range(alive.shape[0]):
        if alive[e] != 0:
            e_int += eint[e]
            e_hg += ehg[e]
    e_coh = 0.0
    e_dmg = 0.0
    for c in range(cstate.shape[0]):
        if cstate[c] != 2:
            el = 0.5 * cL0[c] * cohesive_elastic_energy(c, cprops, dmg, cdn, cds, ctn)
            e_coh += el
            e_dmg += wcoh[c] - el
    ke = 0.0
    for i in range(mass.shape[0]):
        m = mass[i]
        if m <= 0.0:
            continue
        ux = vx[i] if fix_x[i] != 0 else vx[i] - 0.5 * dt * fx[i] / m
        uy = vy[i] if fix_y[i] != 0 else vy[i] - 0.5 * dt * fy[i] / m
        ke += 0.5 * m * (ux * ux + uy * uy)
    return e_int, e_hg, e_coh, e_dmg, ke


def energies(state) -> dict:
    """The energy balance terms [J/m], ``residual`` and ``energy_error`` (module docstring)."""
    s = state
    e_int, e_hg, e_coh, e_dmg, ke = _sums(s.alive, s.eint, s.ehg, s.cstate, s.cL0, s.cprops, s.dmg, s.cdn, s.cds, s.ctn,
                                         s.wcoh, s.mass, s.vx, s.vy, s.fx, s.fy, s.fix_x, s.fix_y,
                                         float(s.scal[S_DTPREV]))
    out = {
        "external": float(s.en[E_EXT] + s.en[E_TOOL]),
        "tool_work": float(s.en[E_TOOL]),
        "internal": float(e_int + e_coh),
        "kinetic": float(ke),
        "hourglass": float(e_hg),
        "damage": float(s.cdis.sum()),
        "removed": float(s.en[E_REMOVED]),
        "friction": float(s.en[E_FRICTION]),
        "viscous": float(s.en[E_VISCOUS]),
        # energy in the tool's penalty springs: tool work - work of the contact forces on the body - friction
        "contact": float(s.en[E_TOOL] - s.en[E_CONTACT_BODY] - s.en[E_FRICTION]),
        # energy in the fragment-contact penalty springs: minus the work they did on the body
        "fragment_contact": float(-s.en[E_FRAG]),
    }
    unaccounted = float(e_dmg + s.en[E_DAMAGE_REMOVED]) - out["damage"]
    out["initial"] = float(s.e_initial) if s.e_initial is not None else out["kinetic"] + out["internal"] + out["hourglass"]
    held = sum(v for k, v in out.items() if k not in ("external", "initial", "tool_work"))
    out["residual"] = out["initial"] + out["external"] - held
    scale = max(abs(out["external"]) + abs(out["initial"]), out["internal"] + out["kinetic"] + out["hourglass"], 1e-300)
    out["energy_error"] = abs(out["residual"]) / scale if scale > 1e-300 else 0.0
    out["kinetic_internal_ratio"] = out["kinetic"] / max(out["internal"] + max(out["hourglass"], 0.0), 1e-300)
    out["added_mass_fraction"] = float(s.added_mass_fraction)
    out["cohesive_unaccounted"] = unaccounted
    return out
