"""The stability matrix: stiff and extreme cases across the scene space (issue 8).

Each case is a base scene plus dotted overrides. A case passes when it either completes
with an energy error below 1 %, or ends ``unstable`` / ``failed`` with a diagnosis, or is
rejected up front by the schema with a message naming the field. It never passes with a
NaN in its summary, a hang (every run has a wall-time cap) or a crash of the process.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

BASE = "seed-0deg-fem-quick"
#: short cuts keep the matrix affordable; the physics of each extreme shows in the first microns
SHORT = {"cut.length_um": 15.0, "numerics.n_frames": 0, "numerics.max_wall_time_s": 300.0}
ENERGY_TOLERANCE = 0.01


@dataclass(frozen=True)
class Case:
    name: str
    overrides: dict[str, Any]
    base: str = BASE
    group: str = ""


def cases() -> list[Case]:
    out: list[Case] = []

    def add(group, name, base=BASE, **ov):
        out.append(Case(name=name, overrides={**SHORT, **{k.replace("__", "."): v for k, v in ov.items()}}, base=base, group=group))

    add("stiffness ratio", "fibre/matrix E ratio 100 (default)")
    add("stiffness ratio", "fibre/matrix E ratio 1000", materials__matrix__E_GPa=0.294)
    for k in (1e4, 1e5, 1e6, 1e7, 1e8, 1e9):  # N/mm3: 1e13 .. 1e18 Pa/m
        add("cohesive penalty", f"cohesive penalty {k * 1e9:.0e} Pa/m", materials__interface__penalty_N_mm3=k)
    add("matrix Poisson", "matrix nu 0.49", materials__matrix__nu=0.49)
    for rake in (-20.0, 0.0, 45.0):
        add("rake angle", f"rake {rake:g} deg", tool__rake_angle_deg=rake)
    for r in (0.0, 50.0):
        add("edge radius", f"edge radius {r:g} um", tool__edge_radius_um=r)
    add("depth of cut", "depth 5 um", cut__depth_um=5.0, tool__edge_radius_um=5.0)
    add("depth of cut", "depth 300 um", cut__depth_um=300.0, workpiece__height_um=450.0)
    for v, scaling in ((10.0, 1.0), (10.0, 1e5), (20000.0, 1.0), (20000.0, 5.0)):
        add("cutting speed", f"speed {v / 1000:g} m/s, speed scaling {scaling:g}", cut__speed_mm_s=v, numerics__speed_scaling=scaling)
    for a in range(0, 181, 15):
        add("fibre angle", f"fibre angle {a} deg", workpiece__fibre_angle_deg=float(a))
    for h in (0.5, 1.0, 8.0):
        add("element size", f"element size {h:g} um", numerics__element_size_um=h,
            **({"cut__length_um": 6.0, "workpiece__height_um": 150.0, "workpiece__micro_zone_depth_um": 20.0} if h < 1.5 else {}))
    for d in (0.0, 0.5, 0.99):
        add("SPH damage D", f"hybrid D {d:g}", base="seed-0deg-hybrid-d08-quick",
            physics__sph_damage_matrix=d, physics__sph_damage_fibre=d)
    add("CFL", "CFL 5 (unstable by design)", numerics__cfl=5.0)
    return out


def _finite_summary(summary: dict[str, Any]) -> bool:
    for v in summary.values():
        if isinstance(v, float) and not math.isfinite(v):
            return False
    return True


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
               dt_limit=s.get("dt_limit"), energy_error=s.get("energy_error"),
               max_penetration_um=s.get("max_penetration_um"), cutting_force_N_per_mm=s.get("cutting_force_N_per_mm"),
               thrust_force_N_per_mm=s.get("thrust_force_N_per_mm"))
    diag = s.get("diagnosis") or {}
    row["diagnosis"] = "; ".join(f"{k}: {v}" for k, v in diag.items() if k != "traceback") if diag else ""
    if s["status"] == "ok":
        e = s.get("energy_error")
        row["passed"] = e is not None and abs(e) < ENERGY_TOLERANCE and _finite_summary(s)
        if not row["passed"]:
            row["why_not"] = f"energy error {e} not below {ENERGY_TOLERANCE}"
    else:
        row["passed"] = bool(row["diagnosis"]) and _finite_summary(s)
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
