"""Read side of replicated and staged studies: the trials as points (one per trial and stage, the
means over its replicas), their ranking, the confirmation, the screening's agreement and the
calibration.

A *point* is what a user means by "a trial": its parameters, its stage (``search``, ``screen``,
``check``, ``confirm``), how many replicas ran and ended ok, and per metric the mean, the sample
standard deviation, the standard error and n over the ok replicas (:mod:`store.replicas`).
"""

from __future__ import annotations

import json
from typing import Any

from solver.result import METRICS

from store import replicas as rp
from store.documents import StudyIn

FORCES = ("cutting_force_N_per_mm", "thrust_force_N_per_mm")
# what a point reports: the metrics but the run's cost (wall time, steps)
SUMMARY_METRICS = tuple(m for m in METRICS if m not in ("wall_time_s", "steps"))


def uses_points(kind: str, doc: StudyIn) -> bool:
    """Studies whose trials are judged by points (the others list one job per trial as before)."""
    return kind in ("optimize", "calibrate") or (kind == "sweep" and (doc.replicas > 1 or bool(doc.objectives) or doc.confirm is not None))


def key_str(key: tuple, params: dict) -> str:
    stage, how, ident = key
    return f"{stage}:trial:{ident}" if how == "trial" else f"{stage}:" + json.dumps(rp.params_of(params), sort_keys=True, default=str)


def build(rows: list[dict], doc: StudyIn, kind: str) -> list[dict[str, Any]]:
    """Points from the job rows of :func:`service.report.trials` (in job order)."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault(rp.group_key(r["params"], r["trial_number"]), []).append(r)
    metrics = list(SUMMARY_METRICS) + [o.metric for o in doc.objectives if o.metric not in SUMMARY_METRICS] + \
        [c.metric for c in doc.constraints if c.metric not in SUMMARY_METRICS]
    out = []
    for key, js in groups.items():
        statuses = {j["status"] for j in js}
        status = ("running" if "running" in statuses else "queued") if statuses & {"queued", "running"} else (
            "done" if "done" in statuses else ("cancelled" if statuses == {"cancelled"} else "failed"))
        p = {"key": key_str(key, js[0]["params"]), "stage": key[0], "trial_number": js[0]["trial_number"], "params": rp.params_of(js[0]["params"]),
             "status": status, "job_ids": [j["job_id"] for j in js], "run_ids": [j["run_id"] for j in js if j["run_id"]],
             "errors": sorted({j["error"] for j in js if j.get("error")})[:3]}
        if kind == "calibrate":
            p.update(_calibration_point(doc, js, key[0]))
        else:
            agg = rp.aggregate(js, metrics)
            p.update({k: agg[k] for k in ("replicas", "replicas_ok", "replicas_failed", "replicas_open", "mean", "sd", "sem", "n",
                                           "wall_time_per_run_s")})
            p["metrics"] = {m: v for m, v in agg["mean"].items() if v is not None}
        out.append(p)
    return out


def _calibration_point(doc: StudyIn, js: list[dict], stage: str) -> dict[str, Any]:
    from store import calibration

    by_point: dict[int, list[dict]] = {}
    for j in js:
        by_point.setdefault(int(j["params"].get("point", 0)), []).append(j)
    preds = {i: rp.aggregate(g, ("cutting_force_N_per_mm", "thrust_force_N_per_mm")) for i, g in by_point.items()}
    complete = not any(j["status"] in ("queued", "running") for j in js) and len(by_point) == len(doc.measurements)
    res = calibration.residuals(doc, preds) if complete else None
    value = calibration.misfit(res) if res else None
    ok = sum(a["replicas_ok"] for a in preds.values())
    return {"replicas": len(js), "replicas_ok": ok, "replicas_failed": sum(a["replicas_failed"] for a in preds.values()),
            "replicas_open": sum(a["replicas_open"] for a in preds.values()),
            "mean": {"misfit_sd": value}, "sd": {"misfit_sd": None}, "sem": {"misfit_sd": None}, "n": {"misfit_sd": 1 if res else 0},
            "metrics": {"misfit_sd": value} if value is not None else {}, "residuals": res,
            "wall_time_per_run_s": None}


def _feasible(p: dict, doc: StudyIn) -> bool:
    for c in doc.constraints:
        v = p["mean"].get(c.metric)
        if not rp.finite(v) or (c.op == "<=" and v > c.value) or (c.op == ">=" and v < c.value):
            return False
    return True


def rank(points: list[dict], doc: StudyIn, kind: str, stage: str = "search") -> dict[str, Any] | None:
    """Feasibility, the Pareto front of the means (several objectives) or the ranking with the
    statistically tied trials (one objective) of one stage's finished points."""
    objs = [("misfit_sd", "minimize")] if kind == "calibrate" else [(o.metric, o.direction) for o in doc.objectives]
    items = [p for p in points if p["stage"] == stage]
    for p in items:
        p["feasible"] = p["status"] == "done" and p["replicas_ok"] > 0 and all(rp.finite(p["mean"].get(m)) for m, _ in objs) and _feasible(p, doc)
        p["on_pareto_front"] = False
    if not objs:
        return None
    cands = [p for p in items if p["feasible"]]
    if len(objs) > 1:
        vec = {id(p): [p["mean"][m] if d == "minimize" else -p["mean"][m] for m, d in objs] for p in cands}
        for p in cands:
            v = vec[id(p)]
            p["on_pareto_front"] = not any(all(a <= b for a, b in zip(vec[id(o)], v)) and any(a < b for a, b in zip(vec[id(o)], v))
                                           for o in cands)
        return None
    m, d = objs[0]
    summary = rp.rank_one_objective(items, m, d)
    for p in items:
        p["on_pareto_front"] = bool(p.get("best"))
    if summary is not None:
        summary["stage"] = stage
    return summary


def confirmation(points: list[dict], doc: StudyIn) -> dict[str, Any] | None:
    """The confirmed trials: their search mean and rank beside the confirmed mean and rank."""
    if doc.confirm is None:
        return None
    o = doc.objectives[0]
    summary = rank(points, doc, "optimize", "confirm")
    search = {_link(p): p for p in points if p["stage"] == "search"}
    confirmed = [p for p in points if p["stage"] == "confirm"]
    rows = []
    for p in confirmed:
        s = search.get(_link(p))
        rows.append({"key": p["key"], "trial_number": p["trial_number"], "params": p["params"], "status": p["status"],
                     "search": {"mean": s["mean"].get(o.metric), "sem": s["sem"].get(o.metric), "n": s["n"].get(o.metric), "rank": s.get("rank")} if s else None,
                     "confirm": {"mean": p["mean"].get(o.metric), "sem": p["sem"].get(o.metric), "n": p["n"].get(o.metric),
                                 "replicas": p["replicas"], "replicas_ok": p["replicas_ok"], "rank": p.get("rank")},
                     "best": bool(p.get("best")), "tied": bool(p.get("tied"))})
    rows.sort(key=lambda r: (r["confirm"]["rank"] is None, r["confirm"]["rank"] or 0, (r["search"] or {}).get("rank") or 0))
    done = bool(confirmed) and all(p["status"] not in ("queued", "running") for p in confirmed)
    search_order = [r["key"] for r in sorted((r for r in rows if r["search"] and r["search"]["rank"]), key=lambda r: r["search"]["rank"])]
    confirm_order = [r["key"] for r in rows if r["confirm"]["rank"] is not None]
    c = doc.confirm
    return {"top_k": c.top_k, "replicas": c.replicas, "fidelity": c.fidelity, "scene": c.scene if isinstance(c.scene, str) or c.scene is None else "inline",
            "metric": o.metric, "direction": o.direction, "status": "done" if done else ("running" if confirmed else "waiting"),
            "trials": rows, "ranking": summary,
            "reranked": done and [k for k in search_order if k in confirm_order] != confirm_order}


def _link(p: dict) -> Any:
    return p["trial_number"] if p["trial_number"] is not None else json.dumps(p["params"], sort_keys=True)


def screening(points: list[dict], doc: StudyIn, kind: str) -> dict[str, Any] | None:
    """The screening's box and the agreement of the two fidelities on the refined points."""
    if doc.screen is None:
        return None
    from store import screening as sc
    from store.studies import _is_int_field

    objs = [("misfit_sd", "minimize")] if kind == "calibrate" else [(o.metric, o.direction) for o in doc.objectives]
    screen = [p for p in points if p["stage"] == "screen"]
    finished = [p for p in screen if p["status"] not in ("queued", "running")]
    rows = [(p["params"], [p["mean"].get(m) for m, _ in objs], _feasible(p, doc)) for p in finished if p["status"] == "done"]
    top = sc.top_trials(rows, [d for _, d in objs], doc.screen.top_k)
    out: dict[str, Any] = {"fidelity": doc.screen.fidelity, "n_trials": doc.screen.n_trials, "finished": len(finished),
                           "top_k": doc.screen.top_k, "margin": doc.screen.margin, "top": top}
    if len(finished) >= doc.screen.n_trials and top:
        ints = {n for n in doc.parameters if _is_int_field(n)}
        out["box"] = sc.box_json(sc.box(doc.parameters, top, doc.screen.margin, ints))
    check = {p["trial_number"]: p for p in points if p["stage"] == "check" and p["status"] == "done"}
    search = [p for p in points if p["stage"] == "search" and p["status"] == "done"]
    metrics = [m for m, _ in objs] + ([] if kind == "calibrate" else [m for m in FORCES if m not in [x for x, _ in objs]])
    out["agreement"] = {m: sc.agreement([(check[p["trial_number"]]["mean"].get(m), p["mean"].get(m)) for p in search if p["trial_number"] in check])
                        for m in metrics}
    out["shared_points"] = sum(1 for p in search if p["trial_number"] in check)
    return out



def calibration(points: list[dict], doc: StudyIn) -> dict[str, Any] | None:
    from store import calibration as cal

    trials = [{"params": p["params"], "residuals": p["residuals"], "trial_number": p["trial_number"]}
              for p in points if p["stage"] == "search" and p.get("residuals")]
    return cal.result(doc, trials, doc.scene if isinstance(doc.scene, str) else None)


def annotate_rows(rows: list[dict], points: list[dict]) -> None:
    """Each job row carries its point's stage, aggregate, ranking marks."""
    by_job = {jid: p for p in points for jid in p["job_ids"]}
    for r in rows:
        p = by_job.get(r["job_id"])
        if p is None:
            continue
        r["stage"] = p["stage"]
        r["aggregate"] = {k: p.get(k) for k in ("key", "params", "replicas", "replicas_ok", "mean", "sd", "sem", "n")}
        r["feasible"] = p.get("feasible")
        r["on_pareto_front"] = p.get("on_pareto_front")
        r["tied"] = p.get("tied")
