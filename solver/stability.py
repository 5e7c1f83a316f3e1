"""The stability matrix: stiff and extreme cases across the scene space.

Each case is a base scene plus dotted overrides. A case passes when it

- completes (status ``ok``) with an energy error below 1 % and a finite summary, or
- ends ``unstable`` with a diagnosis naming the check that fired, or ``failed`` with a
  diagnosis that says what to change (``max_steps``), or
- is rejected up front by the schema with a message naming the field.

It does not pass when it completes with a larger energy error, when its summary holds a NaN,
when the run ended on an exception (``run()`` catches it, but that is a crash of the solver),
or when it hit the wall-time cap (that is how a hang shows).

To keep the full matrix affordable on a small machine every case cuts only 10 um with no
frames and a shorter micro zone (the physics of each extreme shows in the first microns: the
time step, the first contact, the first failures); cases at small element sizes also use a
smaller depth and workpiece, scaled with the element size.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

BASE = "seed-0deg-fem-quick"
HYBRID_BASE = "seed-0deg-hybrid-d08-quick"
SHORT = {"cut.length_um": 10.0, "numerics.n_frames": 0, "numerics.max_wall_time_s": 240.0,
         "numerics.n_force_samples": 40, "workpiece.height_um": 170.0, "workpiece.micro_zone_depth_um": 40.0}
#: a tiny workpiece for the small-element cases (depth, edge radius and height scaled down together)
SMALL = {"cut.depth_um": 10.0, "tool.edge_radius_um": 2.0, "workpiece.height_um": 30.0,
         "workpiece.micro_zone_depth_um": 5.0, "cut.length_um": 3.0}
ENERGY_TOLERANCE = 0.01
#: failed runs whose diagnosis check is one of these did not end the way the issue asks
NOT_A_DIAGNOSIS = ("exception", "max_wall_time")


@dataclass(frozen=True)
class Case:
    name: str
    overrides: dict[str, Any]
    base: str = BASE
    group: str = ""
    what: str = ""  # what this case tests (shown in docs/numerics.md)


def cases() -> list[Case]:
    out: list[Case] = []

    def add(group, name, base=BASE, what="", extra=None, **ov):
        over = {**SHORT, **(extra or {}), **{k.replace("__", "."): v for k, v in ov.items()}}
        out.append(Case(name=name, overrides=over, base=base, group=group, what=what))

    add("stiffness ratio", "fibre/matrix E ratio 100 (default)", what="the base case")
    add("stiffness ratio", "fibre/matrix E ratio 1000", materials__matrix__E_GPa=0.294, what="soft matrix, E1/Em = 1000")
    for k in (1e4, 1e5, 1e6, 1e7, 1e8, 1e9):  # N/mm3: 1e13 .. 1e18 Pa/m
        add("cohesive penalty", f"cohesive penalty {k * 1e9:.0e} Pa/m", materials__interface__penalty_N_mm3=k,
            what="the cohesive penalty limits the time step above about 1e16 Pa/m")
    add("matrix Poisson", "matrix nu 0.49", materials__matrix__nu=0.49, what="nearly incompressible matrix (plane strain)")
    add("matrix Poisson", "matrix nu 0.499 (schema limit)", materials__matrix__nu=0.499, what="the schema's largest Poisson ratio")
    add("matrix Poisson", "matrix nu 0.5 (rejected)", materials__matrix__nu=0.5, what="locks in plane strain: rejected up front")
    for rake in (-20.0, 0.0, 45.0):
        add("rake angle", f"rake {rake:g} deg", tool__rake_angle_deg=rake)
    for r in (0.0, 50.0):
        add("edge radius", f"edge radius {r:g} um", tool__edge_radius_um=r)
    add("depth of cut", "depth 5 um", cut__depth_um=5.0, tool__edge_radius_um=5.0, workpiece__height_um=60.0,
        workpiece__micro_zone_depth_um=20.0)
    add("depth of cut", "depth 300 um (cut 4 um)", cut__depth_um=300.0, workpiece__height_um=400.0, cut__length_um=4.0,
        numerics__max_wall_time_s=480.0, what="10 000 elements: a 4 um cut and a longer wall-time cap keep it affordable")
    add("cutting speed", "speed 0.01 m/s, no speed scaling (max_steps 5000)", cut__speed_mm_s=10.0,
        numerics__speed_scaling=1.0, numerics__max_steps=5000,
        what="needs about 1e7 steps: must stop with a message saying what to change")
    add("cutting speed", "speed 0.01 m/s, speed scaling 1000", cut__speed_mm_s=10.0, numerics__speed_scaling=1000.0)
    add("cutting speed", "speed 0.01 m/s, speed scaling 1e5", cut__speed_mm_s=10.0, numerics__speed_scaling=1e5,
        what="tool at 1000 m/s: faster than the matrix wave speed")
    add("cutting speed", "speed 20 m/s, no speed scaling", cut__speed_mm_s=20000.0, numerics__speed_scaling=1.0)
    add("cutting speed", "speed 20 m/s, speed scaling 5", cut__speed_mm_s=20000.0, numerics__speed_scaling=5.0)
    for a in range(0, 181, 15):
        add("fibre angle", f"fibre angle {a} deg", workpiece__fibre_angle_deg=float(a))
    add("element size", "element size 0.5 um", extra=SMALL, numerics__element_size_um=0.5)
    add("element size", "element size 1 um", extra=SMALL, numerics__element_size_um=1.0)
    add("element size", "element size 8 um", numerics__element_size_um=8.0)
    add("element size", "element size 0.1 um (rejected)", extra=SMALL, numerics__element_size_um=0.1,
        what="below the schema's 0.25 um: rejected up front")
    for d in (0.0, 0.5, 0.99):
        # 40 um: the first elements fail (and turn into particles) only after about 10-20 um of cut
        add("SPH damage D", f"hybrid D {d:g} (cut 40 um)", base=HYBRID_BASE, physics__sph_damage_matrix=d, physics__sph_damage_fibre=d,
            cut__length_um=40.0, what="particles carry (1 - D) of the stiffness; D = 0.99 is nearly stress-free")
    add("CFL", "CFL 5 (unstable by design)", numerics__cfl=5.0, what="must end unstable with the guard's diagnosis")
    add("CFL", "CFL 1.0", numerics__cfl=1.0, what="at the stability limit")
    return out


def _finite_summary(summary: dict[str, Any]) -> bool:
    for v in summary.values():
        if isinstance(v, float) and not math.isfinite(v):
            return False
    return True


def judge(status: str, summary: dict[str, Any]) -> tuple[bool, str]:
    """(passed, why not) for a run's summary, by the criterion of the module docstring."""
    if not _finite_summary(summary):
        return False, "a NaN/Inf in the summary"
    diag = summary.get("diagnosis") or {}
    if status == "ok":
        e = summary.get("energy_error")
        if e is None:
            return False, "completed without an energy error in its summary"
        if abs(e) >= ENERGY_TOLERANCE:
            return False, f"completed with energy error {e:.3g}, not below {ENERGY_TOLERANCE:g}"
        return True, ""
    check = diag.get("check")
    if not diag or not check:
        return False, f"ended {status} without a diagnosis"
    if check in NOT_A_DIAGNOSIS:
        return False, f"ended {status} on {check}: {diag.get('what', '')}"
    if status == "failed" and not diag.get("change"):
        return False, f"failed ({check}) without saying what to change"
    return True, ""


def run_case(case: Case) -> dict[str, Any]:
    """Run one case; never raises for the case's own sake."""
    from .run import run
    from .scene import SceneError, load_scene

    row: dict[str, Any] = {"case": case.name, "group": case.group, "base": case.base}
    t0 = time.perf_counter()
    try:
        scene = load_scene(case.base, case.overrides)
    except SceneError as exc:
        row.update(status="rejected", diagnosis=str(exc), wall_time_s=time.perf_counter() - t0, passed=True)
        return row
    s = run(scene).summary()
    row.update(status=s["status"], wall_time_s=s["wall_time_s"], steps=s["steps"], dt_s=s.get("dt_s"),
               dt_limited_by=s.get("dt_limited_by"), energy_error=s.get("energy_error"),
               kinetic_internal_ratio=s.get("kinetic_internal_ratio"), hourglass_energy_ratio=s.get("hourglass_energy_ratio"),
               max_penetration_um=s.get("max_penetration_um"), n_elements=s.get("n_elements"),
               cutting_force_N_per_mm=s.get("cutting_force_N_per_mm"), thrust_force_N_per_mm=s.get("thrust_force_N_per_mm"))
    diag = s.get("diagnosis") or {}
    row["diagnosis"] = "; ".join(f"{k}: {v}" for k, v in diag.items() if k != "traceback") if diag else ""
    row["passed"], why = judge(s["status"], s)
    if why:
        row["why_not"] = why
    return row


def run_matrix(select: Callable[[Case], bool] | None = None, on_row: Callable[[dict], None] | None = None) -> list[dict]:
    rows = []
    for case in cases():
        if select and not select(case):
            continue
        row = run_case(case)
        rows.append(row)
        if on_row:
            on_row(row)
    return rows


def markdown_table(rows: list[dict]) -> str:
    """The matrix as a markdown table (docs/numerics.md)."""

    def num(v, fmt):
        return "-" if v is None else format(v, fmt)

    lines = ["| group | case | status | dt [s] | dt limited by | steps | wall [s] | energy error | KE/IE | max penetration [um] | pass | diagnosis / why not |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lim = str(r.get("dt_limited_by") or "-").replace("|", "/")
        diag = r.get("diagnosis") or ""
        if r["status"] != "rejected":  # keep the check, what happened and what to change
            diag = "; ".join(p for p in diag.split("; ") if p.startswith(("check:", "what:", "change:")))
        text = (r.get("why_not") or "") + (" -- " if r.get("why_not") and diag else "") + diag
        text = text.replace("|", "/").replace("\n", " ")
        lines.append(f"| {r['group']} | {r['case']} | {r['status']} | {num(r.get('dt_s'), '.3g')} | {lim} | {r.get('steps', '-')} | "
                     f"{num(r.get('wall_time_s'), '.1f')} | {num(r.get('energy_error'), '.3g')} | {num(r.get('kinetic_internal_ratio'), '.3g')} | "
                     f"{num(r.get('max_penetration_um'), '.3g')} | "
                     f"{'pass' if r['passed'] else '**FAIL**'} | {text[:400]} |")
    return "\n".join(lines)
