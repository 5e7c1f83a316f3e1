"""Replicated trials: one trial of a study runs as several jobs (replicas of the same scene whose
``numerics.speed_scaling`` differs by 1e-6 relative, which samples the chaotic spread of a
fracturing cut), and what the study reports of it are the means over its replicas.

- :func:`params_of` and :func:`group_key` split a job's params into the trial's parameters and the
  bookkeeping keys (``replica``, ``stage``, ``point``).
- :func:`aggregate` is one trial's summary: per metric the mean over the replicas whose job ended
  ``done`` (a failed or unstable replica is counted in ``replicas - replicas_ok``, never averaged),
  the sample standard deviation (n - 1), the standard error sd / sqrt(n) and n.
- :func:`rank_one_objective` ranks trials by their mean, and marks the best and the trials that are
  statistically tied with it: |mean - mean_best| <= 2 sqrt(sem^2 + sem_best^2).
- :func:`spearman` is Spearman's rank correlation (average ranks for ties).
"""

from __future__ import annotations

import math
from typing import Any, Iterable

#: keys a job's params carry beside the study's parameters
BOOKKEEPING = ("replica", "stage", "point")
STAGES = ("search", "screen", "check", "confirm")
TIE_SIGMAS = 2.0


def finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def params_of(params: dict) -> dict:
    """The trial's parameters without the bookkeeping keys."""
    return {k: v for k, v in (params or {}).items() if k not in BOOKKEEPING}


def stage_of(params: dict) -> str:
    return (params or {}).get("stage") or "search"


def group_key(params: dict, trial_number: int | None) -> tuple:
    """Jobs of one trial: same stage and optuna trial number (optimize, calibrate), or the same
    parameters (sweeps, whose points have no trial number)."""
    stage = stage_of(params)
    if trial_number is not None:
        return (stage, "trial", int(trial_number))
    return (stage, "params", repr(sorted(params_of(params).items())))


def stats(values: Iterable[float]) -> dict[str, Any]:
    """mean, sample standard deviation (n - 1), standard error and n of the finite values."""
    vals = [float(v) for v in values if finite(v)]
    n = len(vals)
    if not n:
        return {"mean": None, "sd": None, "sem": None, "n": 0}
    mean = sum(vals) / n
    sd = math.sqrt(sum((v - mean) ** 2 for v in vals) / (n - 1)) if n > 1 else None
    return {"mean": mean, "sd": sd, "sem": None if sd is None else sd / math.sqrt(n), "n": n}


def aggregate(jobs: list[dict], metrics: Iterable[str] | None = None) -> dict[str, Any]:
    """One trial from its replica jobs (dicts with ``status`` and ``metrics``).

    Only jobs that ended ``done`` (their run ok, or a cached ok run) enter the statistics.
    Returns ``replicas`` (jobs), ``replicas_ok``, ``replicas_failed``, ``replicas_open`` and
    per metric ``mean``, ``sd``, ``sem``, ``n`` (dicts keyed by metric)."""
    ok = [j for j in jobs if j.get("status") == "done" and j.get("metrics")]
    if metrics is None:
        names: list[str] = []
        for j in ok:
            for k, v in j["metrics"].items():
                if finite(v) and k not in names:
                    names.append(k)
        metrics = names
    out: dict[str, Any] = {
        "replicas": len(jobs), "replicas_ok": len(ok),
        "replicas_failed": sum(1 for j in jobs if j.get("status") in ("failed", "cancelled") or (j.get("status") == "done" and not j.get("metrics"))),
        "replicas_open": sum(1 for j in jobs if j.get("status") in ("queued", "running")),
        "mean": {}, "sd": {}, "sem": {}, "n": {},
    }
    for m in metrics:
        st = stats(j["metrics"].get(m) for j in ok)
        for key in ("mean", "sd", "sem", "n"):
            out[key][m] = st[key]
    walls = [j.get("wall_time_s") for j in jobs if finite(j.get("wall_time_s"))]
    out["wall_time_per_run_s"] = sum(walls) / len(walls) if walls else None
    return out


def combined_sem(a: float | None, b: float | None) -> float:
    return math.sqrt((a or 0.0) ** 2 + (b or 0.0) ** 2)


def rank_one_objective(items: list[dict], metric: str, direction: str) -> dict[str, Any] | None:
    """Rank trials (dicts with ``mean``/``sem`` dicts, a ``key`` and ``feasible``) by the mean of
    ``metric``. Marks ``rank`` (1 = best), ``best`` and ``tied`` (within two combined standard
    errors of the best, the best itself excluded) on each ranked item and answers the summary:
    the best's key, mean and standard error and the keys of the tied trials."""
    sign = 1.0 if direction == "minimize" else -1.0
    cands = [it for it in items if it.get("feasible", True) and finite((it.get("mean") or {}).get(metric))]
    for it in items:
        it["rank"], it["best"], it["tied"] = None, False, False
    if not cands:
        return None
    cands.sort(key=lambda it: sign * it["mean"][metric])
    best = cands[0]
    mb, sb = best["mean"][metric], (best.get("sem") or {}).get(metric)
    tied = []
    for r, it in enumerate(cands, start=1):
        it["rank"] = r
        if it is best:
            it["best"] = True
            continue
        s = (it.get("sem") or {}).get(metric)
        it["tied"] = abs(it["mean"][metric] - mb) <= TIE_SIGMAS * combined_sem(s, sb)
        if it["tied"]:
            tied.append(it)
    return {"metric": metric, "direction": direction, "best": best["key"], "mean": mb, "sem": sb,
            "n": (best.get("n") or {}).get(metric), "tied": [it["key"] for it in tied],
            "rule": f"|mean - mean_best| <= {TIE_SIGMAS:g} sqrt(sem^2 + sem_best^2)"}


def _ranks(values: list[float]) -> list[float]:
    order = sorted(range(len(values)), key=lambda i: values[i])
    out = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            out[order[k]] = (i + j) / 2 + 1
        i = j + 1
    return out


def spearman(x: list[float], y: list[float]) -> float | None:
    """Spearman's rank correlation over the pairs where both are finite; None below 3 pairs or
    without spread."""
    pairs = [(a, b) for a, b in zip(x, y) if finite(a) and finite(b)]
    if len(pairs) < 3:
        return None
    rx, ry = _ranks([a for a, _ in pairs]), _ranks([b for _, b in pairs])
    n = len(pairs)
    mx, my = sum(rx) / n, sum(ry) / n
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    sxx = sum((a - mx) ** 2 for a in rx)
    syy = sum((b - my) ** 2 for b in ry)
    if sxx <= 0 or syy <= 0:
        return None
    return sxy / math.sqrt(sxx * syy)
