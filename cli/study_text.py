"""Plain-text lines of what a study concludes (``fibrecut status ID``): the best trial with its
standard error and the trials statistically tied with it, the confirmation, the screening's
agreement and a calibration's fitted values."""

from __future__ import annotations

import json
from typing import Any


def _pm(mean: Any, sem: Any) -> str:
    if not isinstance(mean, (int, float)):
        return "-"
    return f"{mean:.4g}" + (f" +- {sem:.2g}" if isinstance(sem, (int, float)) else "")


def summary_lines(s: dict[str, Any]) -> list[str]:
    out = []
    for b in s.get("best") or []:
        vals = ", ".join(f"{m} {_pm(v, (b.get('sem') or {}).get(m))}" for m, v in (b.get("objectives") or {}).items())
        reps = f" (mean of {b['replicas_ok']}/{b['replicas']} replicas{', confirmed' if b.get('confirmed') else ''})" if b.get("replicas", 1) > 1 else ""
        label = f"trial {b['trial_number']}" if b.get("trial_number") is not None else "point"
        out.append(f"  best: {label} {json.dumps(b['params'])} -> {vals}{reps}")
        if "tied" in b:
            tied = [t.get("trial_number") if t.get("trial_number") is not None else json.dumps(t["params"]) for t in b["tied"]]
            out.append(f"  statistically tied with it (within 2 combined standard errors): {', '.join(map(str, tied)) or 'none'}")
    conf = s.get("confirmation")
    if conf and not conf["trials"]:
        out.append(f"  confirmation: the best {conf['top_k']} run again when the search has ended")
    elif conf:
        out.append(f"  confirmation ({conf['status']}): " + "; ".join(
            f"trial {r['trial_number']} rank {(r.get('search') or {}).get('rank')} -> {r['confirm']['rank']} ({_pm(r['confirm']['mean'], r['confirm']['sem'])})"
            for r in conf["trials"]))
    scr = s.get("screening")
    if scr and scr.get("agreement"):
        for m, a in scr["agreement"].items():
            if a.get("n"):
                rho = f"{a['spearman']:.2f}" if isinstance(a.get("spearman"), (int, float)) else "-"
                out.append(f"  screening vs refined on {a['n']} shared points, {m}: Spearman {rho}, offset {_pm(a['mean_offset'], a['offset_sem'])}")
    cal = s.get("calibration")
    if cal:
        vals = ", ".join(f"{k} = {_pm(v, (cal['uncertainty'].get(k) or {}).get('sd'))}" for k, v in cal["values"].items())
        out.append(f"  calibration: {vals}; misfit {cal['misfit']:.3g} sd, leave-one-out {cal['loo_error']['rms_sd']:.3g} sd")
    return out
