"""Screen, then refine: a cheap fidelity searches the whole parameter ranges, the study's own
fidelity searches only the box around the screening's best trials.

- :func:`top_trials`: the screening's ``top_k`` best finished trials (one objective: by value;
  several: by the sum of their ranks over the objectives; infeasible trials last);
- :func:`box`: per parameter the range those trials span, widened on each side by ``margin`` times
  the parameter's full range and clipped to it (log ranges in log space, stepped ranges snapped
  outwards to their step, explicit values: the values the top trials use);
- :func:`agreement`: on the shared points (every refined trial is also run once at the screening
  fidelity, stage ``check``) per metric Spearman's rank correlation between the two fidelities and
  the mean offset (refined mean - screening value) with its standard deviation and standard error,
  also relative to the screening value. A rank correlation near 1 says the cheap model ranks the
  region's points as the numerical model does, even when it is offset.
"""

from __future__ import annotations

import math
from typing import Any

from .replicas import finite, spearman, stats
from .documents import ParameterSpec


def top_trials(values: list[tuple[dict, list[float], bool]], directions: list[str], top_k: int) -> list[dict]:
    """``values``: (params, objective values, feasible) of the finished screening trials."""
    signs = [1.0 if d == "minimize" else -1.0 for d in directions]
    rows = [(p, [s * v for s, v in zip(signs, vals)], feas) for p, vals, feas in values if all(finite(v) for v in vals)]
    if not rows:
        return []
    if len(signs) == 1:
        rows.sort(key=lambda r: (not r[2], r[1][0]))
    else:
        ranks = [[0] * len(rows) for _ in signs]
        for k in range(len(signs)):
            order = sorted(range(len(rows)), key=lambda i: rows[i][1][k])
            for r, i in enumerate(order):
                ranks[k][i] = r
        total = [sum(ranks[k][i] for k in range(len(signs))) for i in range(len(rows))]
        idx = sorted(range(len(rows)), key=lambda i: (not rows[i][2], total[i]))
        rows = [rows[i] for i in idx]
    return [r[0] for r in rows[:top_k]]


def box(parameters: dict[str, ParameterSpec], top: list[dict], margin: float, int_fields: set[str]) -> dict[str, ParameterSpec]:
    """The refinement box around the top trials' parameters."""
    out = {}
    for name, spec in parameters.items():
        vals = [t[name] for t in top if name in t]
        if not vals:
            out[name] = spec
            continue
        if spec.values is not None:
            out[name] = ParameterSpec(values=[v for v in spec.values if v in vals])
            continue
        if spec.log:
            lo, hi = math.log(min(vals)), math.log(max(vals))
            full = math.log(spec.high) - math.log(spec.low)
            lo, hi = math.exp(max(math.log(spec.low), lo - margin * full)), math.exp(min(math.log(spec.high), hi + margin * full))
        else:
            full = spec.high - spec.low
            lo, hi = max(spec.low, min(vals) - margin * full), min(spec.high, max(vals) + margin * full)
            if spec.step:
                lo = spec.low + math.floor((lo - spec.low) / spec.step + 1e-9) * spec.step
                hi = min(spec.high, spec.low + math.ceil((hi - spec.low) / spec.step - 1e-9) * spec.step)
        if name in int_fields:
            lo, hi = math.floor(lo), math.ceil(hi)
        if not hi > lo:
            out[name] = ParameterSpec(values=[lo])
            continue
        out[name] = ParameterSpec(low=lo, high=hi, log=spec.log, step=spec.step)
    return out


def box_json(b: dict[str, ParameterSpec]) -> dict[str, Any]:
    return {k: v.model_dump(exclude_none=True, exclude_defaults=True) for k, v in b.items()}


def agreement(pairs: list[tuple[float | None, float | None]]) -> dict[str, Any]:
    """(screening value, refined mean) of the shared points of one metric."""
    ok = [(a, b) for a, b in pairs if finite(a) and finite(b)]
    diffs = [b - a for a, b in ok]
    rel = [(b - a) / abs(a) for a, b in ok if a != 0]
    d = stats(diffs)
    r = stats(rel)
    return {"n": len(ok), "spearman": spearman([a for a, _ in ok], [b for _, b in ok]),
            "mean_offset": d["mean"], "offset_sd": d["sd"], "offset_sem": d["sem"],
            "relative_offset": r["mean"], "relative_offset_sem": r["sem"]}
