"""Accuracy against run time: convergence studies of one scene.

The same scene runs at several levels of one numerical parameter (element size, mass
scaling, speed scaling). For every run we report the error of each metric against the
finest run and, where three levels with a constant refinement ratio allow it, against a
Richardson extrapolation (Roache 1998, "Verification and Validation in Computational Science
and Engineering", ch. 5):

    p     = ln((f1 - f2) / (f2 - f3)) / ln(r)          (observed order, r = h1/h2 = h2/h3)
    f_ext = f3 + (f3 - f2) / (r^p - 1)

Then the cheapest level whose error is within a user-given tolerance.

**Replicas.** Cutting with fracture is chaotic: which element fails first decides the fracture
sequence, and a relative change of 1e-6 in the cutting speed moves the steady cutting force of
the small 0-degree scene between about 0.2 and 1.4 N/mm (docs/numerics.md). A single run is one
sample of that spread, so the difference of two single runs at h and h/2 mixes the
discretisation error with the chaotic spread. With ``replicas`` = n each level runs n times with
the tool speed multiplied by 1 + k 1e-6 (k = 0 .. n-1, physically nothing) and reports the mean of
each metric with its standard deviation and standard error (sd / sqrt(n)); errors are those of the
means, and each comes with its own uncertainty (the standard error of the difference over the
reference), so a user sees whether a difference is resolved at all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

METRICS = ("cutting_force_N_per_mm", "thrust_force_N_per_mm", "damage_depth_um", "bounce_back_um")
#: each level's own accuracy indicators, carried into its row
INDICATORS = ("energy_error", "kinetic_internal_ratio", "added_mass_fraction", "hourglass_energy_ratio", "max_penetration_um",
              "dt_s", "dt_limited_by", "n_elements")

#: parameter -> (dotted field, default levels from coarse to fine, "finer" means smaller?)
PARAMETERS = {
    "element_size": ("numerics.element_size_um", [8.0, 4.0, 2.0], True),
    "mass_scaling": ("numerics.mass_scaling", [100.0, 10.0, 1.0], True),
    "speed_scaling": ("numerics.speed_scaling", [20000.0, 10000.0, 5000.0], True),
}


#: relative tool-speed perturbation between replicas (samples the chaotic spread; physically nothing)
REPLICA_PERTURBATION = 1e-6
SPEED_SCALING_MAX = 1.0e5  # the scene field's upper bound (the perturbation goes down from it)
#: indicators where a level of replicas reports the worst (largest) replica
WORST_OF = ("energy_error", "kinetic_internal_ratio", "added_mass_fraction", "hourglass_energy_ratio", "max_penetration_um")


def replica_speed_scalings(base: float, replicas: int) -> list[float]:
    """The speed scalings of ``replicas`` runs around ``base``: base (1 + k REPLICA_PERTURBATION),
    k = 0 .. replicas-1, downwards instead when upwards would pass the field's bound."""
    sign = 1.0 if base * (1.0 + replicas * REPLICA_PERTURBATION) <= SPEED_SCALING_MAX else -1.0
    return [base * (1.0 + sign * k * REPLICA_PERTURBATION) for k in range(int(replicas))]


def combine_replicas(summaries: list[dict[str, Any]], metrics: tuple[str, ...] = METRICS) -> dict[str, Any]:
    """One level's summary from its replicas: the metrics' means over the ok replicas with
    ``{m}_sd``, ``{m}_sem`` and ``{m}_samples``; the worst replica's accuracy indicators; the total
    wall time (``wall_time_per_run_s`` the mean); status ok if every replica is ok, else the first
    other status (``replicas_ok`` counts the ok ones)."""
    ok = [s for s in summaries if s.get("status") == "ok"]
    out = dict(summaries[0])
    bad = next((s for s in summaries if s.get("status") != "ok"), None)
    if bad is not None:
        out.update({k: bad.get(k) for k in ("status", "diagnosis") if k in bad})
    out["replicas"] = len(summaries)
    out["replicas_ok"] = len(ok)
    walls = [float(s.get("wall_time_s") or 0.0) for s in summaries]
    out["wall_time_s"] = sum(walls)
    out["wall_time_per_run_s"] = sum(walls) / len(walls)
    for k in WORST_OF:
        vals = [s.get(k) for s in summaries if isinstance(s.get(k), (int, float)) and math.isfinite(s.get(k))]
        if vals:
            out[k] = max(vals)
    for m in metrics:
        vals = [float(s[m]) for s in ok if isinstance(s.get(m), (int, float)) and math.isfinite(s[m])]
        out[f"{m}_samples"] = vals
        if not vals:
            out[m], out[f"{m}_sd"], out[f"{m}_sem"] = None, None, None
            continue
        mean = sum(vals) / len(vals)
        sd = math.sqrt(sum((v - mean) ** 2 for v in vals) / (len(vals) - 1)) if len(vals) > 1 else None
        out[m] = mean
        out[f"{m}_sd"] = sd
        out[f"{m}_sem"] = None if sd is None else sd / math.sqrt(len(vals))
    return out


@dataclass
class Level:
    value: float
    summary: dict[str, Any]

    @property
    def wall_time_s(self) -> float:
        return float(self.summary.get("wall_time_s") or 0.0)


@dataclass
class Convergence:
    parameter: str
    field: str
    levels: list[Level]
    rows: list[dict[str, Any]] = field(default_factory=list)
    observed_order: dict[str, float | None] = field(default_factory=dict)
    extrapolated: dict[str, float | None] = field(default_factory=dict)
    cheapest: dict[str, Any] | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"parameter": self.parameter, "field": self.field, "rows": self.rows,
                "observed_order": self.observed_order, "extrapolated": self.extrapolated, "cheapest": self.cheapest}


def relative_error(value: float | None, reference: float | None, scale: float) -> float | None:
    """|value - reference| / max(|reference|, scale); scale guards a reference near zero."""
    if value is None or reference is None or not (math.isfinite(value) and math.isfinite(reference)):
        return None
    return abs(value - reference) / max(abs(reference), scale)


def richardson(f1: float, f2: float, f3: float, r: float) -> tuple[float | None, float | None]:
    """Observed order p and extrapolated value from three levels coarse->fine with ratio r.

    Returns (None, None) when the sequence is not monotonically converging (oscillating or
    diverging differences), where Richardson extrapolation does not apply.
    """
    d12, d23 = f1 - f2, f2 - f3
    if d23 == 0.0 or d12 == 0.0 or (d12 > 0) != (d23 > 0) or abs(d23) >= abs(d12) or r <= 1.0:
        return None, None
    p = math.log(d12 / d23) / math.log(r)
    return p, f3 + (f3 - f2) / (r**p - 1.0)


def analyse(parameter: str, field_name: str, levels: list[Level], tolerance: float = 0.05,
            target: str = "thrust_force_N_per_mm", metrics: tuple[str, ...] = METRICS) -> Convergence:
    """Errors against the finest level (the last one) and Richardson, the observed order, the cheapest level."""
    conv = Convergence(parameter=parameter, field=field_name, levels=levels)
    ok = [lv for lv in levels if lv.summary.get("status") == "ok"]
    finest = ok[-1] if ok else None
    ratio = None
    if len(ok) >= 3:
        r1, r2 = ok[-3].value / ok[-2].value, ok[-2].value / ok[-1].value
        if r1 > 1 and abs(r1 - r2) < 1e-6 * r1:
            ratio = r1
    for m in metrics:
        conv.observed_order[m], conv.extrapolated[m] = (None, None)
        if ratio is not None:
            vals = [lv.summary.get(m) for lv in ok[-3:]]
            if all(v is not None for v in vals):
                conv.observed_order[m], conv.extrapolated[m] = richardson(*vals, ratio)
    for lv in levels:
        row = {"value": lv.value, "status": lv.summary.get("status"), "wall_time_s": lv.wall_time_s,
               "steps": lv.summary.get("steps")}
        for k in INDICATORS:
            row[k] = lv.summary.get(k)
        if lv.summary.get("diagnosis"):
            row["diagnosis"] = {k: v for k, v in lv.summary["diagnosis"].items() if k != "traceback"}
        if "replicas" in lv.summary:
            row["replicas"], row["replicas_ok"] = lv.summary["replicas"], lv.summary.get("replicas_ok")
            row["wall_time_per_run_s"] = lv.summary.get("wall_time_per_run_s")
        for m in metrics:
            v = lv.summary.get(m)
            scale = max([abs(x.summary.get(m) or 0.0) for x in ok] + [1e-12]) * 1e-3
            row[m] = v
            row[f"{m}_error_vs_finest"] = relative_error(v, finest.summary.get(m), scale) if finest and lv is not finest else None
            row[f"{m}_error_vs_richardson"] = relative_error(v, conv.extrapolated[m], scale)
            sem = lv.summary.get(f"{m}_sem")
            if f"{m}_sem" in lv.summary:
                row[f"{m}_sd"], row[f"{m}_sem"] = lv.summary.get(f"{m}_sd"), sem
                row[f"{m}_samples"] = lv.summary.get(f"{m}_samples")
                ref_sem = finest.summary.get(f"{m}_sem") if finest else None
                ref = finest.summary.get(m) if finest else None
                if lv is not finest and sem is not None and ref_sem is not None and ref is not None:
                    # the standard error of the difference of two means, relative to the reference
                    row[f"{m}_error_uncertainty"] = math.sqrt(sem**2 + ref_sem**2) / max(abs(ref), scale)
        conv.rows.append(row)
    key_r, key_f = f"{target}_error_vs_richardson", f"{target}_error_vs_finest"
    candidates = []
    for row in conv.rows:
        err = row.get(key_r) if row.get(key_r) is not None else row.get(key_f)
        if row["status"] == "ok" and err is not None and err <= tolerance:
            candidates.append((row["wall_time_s"], row, err))
    if candidates:
        wall, row, err = min(candidates, key=lambda c: c[0])
        conv.cheapest = {"value": row["value"], "wall_time_s": wall, "error": err, "target": target, "tolerance": tolerance,
                         "against": "richardson" if row.get(key_r) is not None else "finest"}
    return conv


def run_convergence(scene_ref: str, parameter: str, levels: list[float], overrides: dict[str, Any] | None = None,
                    tolerance: float = 0.05, target: str = "thrust_force_N_per_mm",
                    on_level: Callable[[float, dict], None] | None = None, replicas: int = 1) -> Convergence:
    """Run ``scene_ref`` at each level of ``parameter`` (coarse to fine) and analyse; with
    ``replicas`` > 1 each level is the mean of that many runs (module docstring)."""
    from .run import run
    from .scene import load_scene

    if parameter not in PARAMETERS:
        raise ValueError(f"parameter = {parameter!r}: allowed {', '.join(PARAMETERS)}")
    field_name, _, _ = PARAMETERS[parameter]
    done = []
    if int(replicas) < 1:
        raise ValueError(f"replicas = {replicas!r}: must be an integer >= 1")
    for value in levels:
        scene = load_scene(scene_ref, {**(overrides or {}), field_name: value})
        if replicas == 1:
            summary = run(scene).summary()
        else:
            summary = combine_replicas([
                run(load_scene(scene_ref, {**(overrides or {}), field_name: value, "numerics.speed_scaling": ss})).summary()
                for ss in replica_speed_scalings(float(scene.numerics.speed_scaling), replicas)])
        done.append(Level(value, summary))
        if on_level:
            on_level(value, summary)
    return analyse(parameter, field_name, done, tolerance=tolerance, target=target)


def plot_work_precision(convs: list[Convergence], path: str, target: str = "thrust_force_N_per_mm") -> str:
    """Error against wall time, log-log, one line per parameter (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=120)
    for conv in convs:
        pts = []
        for row in conv.rows:
            err = row.get(f"{target}_error_vs_richardson")
            if err is None:
                err = row.get(f"{target}_error_vs_finest")
            if err is not None and err > 0 and row["wall_time_s"] > 0:
                pts.append((row["wall_time_s"], err, row["value"]))
        if pts:
            values = [r["value"] for r in conv.rows]
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=f"{conv.field} ({min(values):g}-{max(values):g})")
            for t, e, v in pts:
                ax.annotate(f"{v:g}", (t, e), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xlabel("wall time per run [s]")
    ax.set_ylabel(f"relative error of {target}")
    ax.set_title("Work-precision")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
