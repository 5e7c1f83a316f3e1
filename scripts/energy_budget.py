"""Where the tool's work went in a cut: the terms of the energy balance at the end of runs, over replicas.

    python scripts/energy_budget.py RUN.h5 [RUN.h5 ...]

Reads the energy histories of run files (``fibrecut run SCENE -o RUN.h5``, or ``scripts/validation.py measure
ROW --frames FOLDER N``) and prints, per term of the balance (solver/fem/energy.py), its value at the end of the
run in J/m (per unit width of cut) and as a force: the term divided by the tool's travel, in N/mm, the part of
the mean cutting force it accounts for (the tool's work over the travel is the mean of Fc). With several files,
the mean +- standard error over them (the replicas of one scene).

The terms: the tool's work; friction on the tool; damage (the cohesive interfaces' softening); removed (the
energy the deleted elements held: elastic, plastic and their crack bands' dissipation); internal and hourglass
(what the living elements hold); kinetic; the contact springs; the viscous damping; the balance's residual.
"""

from __future__ import annotations

import sys

import h5py
import numpy as np

TERMS = ["tool_work", "friction", "damage", "removed", "internal", "hourglass", "kinetic", "contact",
         "fragment_contact", "viscous", "residual"]


def budget(path: str) -> dict[str, float]:
    """Each term at the end of the run [J/m] and the tool's travel [um] (key ``travel_um``)."""
    with h5py.File(path, "r") as f:
        e = f["energies"]
        out = {k: float(e[k][-1]) for k in TERMS if k in e}
        out["travel_um"] = float(f["forces/travel_um"][-1])
    return out


def main(argv: list[str]) -> int:
    if not argv or any(a.startswith("-") for a in argv):
        print(__doc__, file=sys.stderr)
        return 2
    try:
        runs = [budget(p) for p in argv]
    except (OSError, KeyError) as exc:
        print(f"not a run file with an energy history: {exc}", file=sys.stderr)
        return 2
    n = len(runs)
    print(f"n = {n} run(s); value at the end [J/m] and per unit travel [N/mm]" + (", mean +- standard error" if n > 1 else ""))
    def se(a):
        return f" +- {a.std(ddof=1) / np.sqrt(n):.3g}" if n > 1 else ""

    for term in TERMS:
        if not all(term in r for r in runs):
            continue
        v = np.array([r[term] for r in runs])
        f = np.array([r[term] / (r["travel_um"] * 1e-6) / 1e3 for r in runs])  # J/m per m of travel -> N/mm
        print(f"{term:18s} {v.mean():9.4g}{se(v):12s} J/m  {f.mean():8.3g}{se(f):10s} N/mm")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
