"""Read side of studies: the status answer, the trials, the best trials / Pareto front,
convergence errors against the finest level, and the CSV export."""

from __future__ import annotations

import csv
import io
import math
import time
from typing import Any

import sqlalchemy as sa

from store import queue
from store.documents import StudyIn
from store.models import Job, Run, Study

from . import points

SUMMARY_METRICS = points.SUMMARY_METRICS


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def trials(s, study: Study) -> list[dict[str, Any]]:
    out = _job_rows(s, study)
    return _judge(s, study, out)


def _job_rows(s, study: Study) -> list[dict[str, Any]]:
    rows = s.execute(sa.select(Job, Run).outerjoin(Run, Run.id == Job.run_id)
                     .where(Job.study_id == study.id).order_by(Job.index)).all()
    out = []
    for job, run in rows:
        metrics = {k: v for k, v in (run.summary or {}).items() if k not in ("warnings", "diagnosis", "scene", "fidelity", "status")} if run else None
        out.append({
            "job_id": job.id, "index": job.index, "trial_number": job.trial_number, "params": job.params,
            "metrics": metrics, "status": job.status, "run_status": run.status if run else None, "run_id": job.run_id,
            "cached": job.cached, "attempts": job.attempts, "progress": job.progress, "eta_s": job.eta_s,
            "message": job.message, "error": job.error, "wall_time_s": run.wall_time_s if run else None,
            "stage": (job.params or {}).get("stage") or "search",
        })
    return out


def _judge(s, study: Study, out: list[dict[str, Any]]) -> list[dict[str, Any]]:
    doc = StudyIn.model_validate(study.document)
    if points.uses_points(study.kind, doc):
        pts = points.build(out, doc, study.kind)
        points.rank(pts, doc, study.kind)
        points.confirmation(pts, doc)
        points.annotate_rows(out, pts)
    elif study.kind == "convergence":
        _convergence_errors(out, s, study)
    return out


def study_points(s, study: Study) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The study's points (one per trial and stage) and what the study concludes from them:
    ``ranking`` (one objective), ``confirmation``, ``screening``, ``calibration``."""
    doc = StudyIn.model_validate(study.document)
    if not points.uses_points(study.kind, doc):
        return [], {}
    pts = points.build(_job_rows(s, study), doc, study.kind)
    ranking = points.rank(pts, doc, study.kind)
    out: dict[str, Any] = {"ranking": ranking, "confirmation": points.confirmation(pts, doc),
                           "screening": points.screening(pts, doc, study.kind)}
    if study.kind == "calibrate":
        out["calibration"] = points.calibration(pts, doc)
    return pts, out


def _convergence_errors(out: list[dict], s, study: Study) -> None:
    """Relative error of each level's metrics against the finest finished level."""
    scenes = {j.id: j.scene for j in s.execute(sa.select(Job).where(Job.study_id == study.id)).scalars()}

    def fineness(t):
        n = scenes[t["job_id"]].get("numerics", {})
        return (n.get("element_size_um", 0), n.get("mass_scaling", 1), n.get("speed_scaling", 1))

    done = [t for t in out if t["status"] == "done" and t["metrics"]]
    if not done:
        return
    if int((study.document or {}).get("replicas", 1)) > 1:
        _replica_errors(out, done, fineness)
        return
    finest = min(done, key=fineness)
    for t in out:
        t["reference_job_id"] = finest["job_id"]
        if not t["metrics"]:
            continue
        err = {}
        for k in SUMMARY_METRICS:
            a, b = t["metrics"].get(k), finest["metrics"].get(k)
            if _finite(a) and _finite(b) and b != 0:
                err[k] = abs(a - b) / abs(b)
        t["error_vs_finest"] = err


def _level_key(t: dict) -> str:
    return repr(sorted((k, v) for k, v in t["params"].items() if k != "replica"))


def _replica_errors(out: list[dict], done: list[dict], fineness) -> None:
    """Convergence with replicas: each level is the mean of its finished replicas (their runs with
    status ok; solver.convergence.combine_replicas), and every trial of a level carries the level's
    aggregate (``level``), the relative error of the level's mean against the finest level's mean
    (``error_vs_finest``) and the standard error of that error (``error_uncertainty``:
    sqrt(sem^2 + sem_finest^2) / |mean_finest|), so a user sees whether a difference is resolved."""
    from solver.convergence import combine_replicas

    groups: dict[str, list[dict]] = {}
    for t in done:
        groups.setdefault(_level_key(t), []).append(t)
    levels = {}
    for key, ts in groups.items():
        summ = combine_replicas([{**t["metrics"], "status": t["run_status"], "wall_time_s": t["wall_time_s"]} for t in ts],
                                SUMMARY_METRICS)
        levels[key] = {
            "params": {k: v for k, v in ts[0]["params"].items() if k != "replica"},
            "replicas": len(ts), "replicas_ok": summ["replicas_ok"], "wall_time_per_run_s": summ["wall_time_per_run_s"],
            "mean": {m: summ.get(m) for m in SUMMARY_METRICS}, "sd": {m: summ.get(f"{m}_sd") for m in SUMMARY_METRICS},
            "sem": {m: summ.get(f"{m}_sem") for m in SUMMARY_METRICS},
        }
    finest_key = _level_key(min(done, key=fineness))
    ref = levels[finest_key]
    ref_job = min((t for t in groups[finest_key]), key=lambda t: t["params"].get("replica", 0))["job_id"]
    for t in out:
        t["reference_job_id"] = ref_job
        lv = levels.get(_level_key(t))
        if lv is None or not t["metrics"]:
            continue
        t["level"] = {**lv, "is_finest": lv is ref}
        err, unc = {}, {}
        for m in SUMMARY_METRICS:
            a, b = lv["mean"][m], ref["mean"][m]
            if _finite(a) and _finite(b) and b != 0:
                err[m] = abs(a - b) / abs(b)
                sa_, sb_ = lv["sem"][m], ref["sem"][m]
                if lv is not ref and _finite(sa_) and _finite(sb_):
                    unc[m] = math.sqrt(sa_**2 + sb_**2) / abs(b)
        t["error_vs_finest"] = err
        t["error_uncertainty"] = unc


def study_out(s, study: Study, with_document: bool = True) -> dict[str, Any]:
    counts, running_progress, first = queue.counts_and_progress(s, study.id)
    finished = counts["done"] + counts["failed"] + counts["cancelled"]
    planned = max(study.planned_jobs, finished + counts["queued"] + counts["running"], 1)
    progress = min(1.0, (finished + float(running_progress)) / planned)
    eta = None
    # stages run jobs of very different cost (a screening's analytic runs take milliseconds, a
    # confirmation's full scenes minutes): the elapsed time per job says nothing of the rest
    staged = bool((study.document or {}).get("screen") or (study.document or {}).get("confirm"))
    if study.status in ("queued", "running") and 0 < progress < 1 and not staged:
        if first:
            elapsed = time.time() - first
            eta = elapsed / progress * (1 - progress)
    out = {
        "id": study.id, "name": study.name, "kind": study.kind, "status": study.status, "counts": counts,
        "planned_jobs": study.planned_jobs, "progress": progress, "eta_s": eta, "created_at": study.created_at,
        "updated_at": study.updated_at, "finished_at": study.finished_at, "error": study.error,
        "document": study.document if with_document else None,
    }
    if with_document and points.uses_points(study.kind, StudyIn.model_validate(study.document)):
        pts, conclusions = study_points(s, study)
        out.update(conclusions)
        out["best"] = _best(pts, conclusions, study)
    return out


def _best(pts: list[dict], conclusions: dict, study: Study) -> list[dict[str, Any]] | None:
    """The best trial (one objective; after a finished confirmation its confirmed ranking) with its
    standard error and the trials statistically tied with it, or the Pareto front of the means."""
    doc = study.document
    metrics = ["misfit_sd"] if study.kind == "calibrate" else [o["metric"] for o in doc.get("objectives", [])]
    if not metrics:
        return None
    conf = conclusions.get("confirmation")
    ranking = conclusions.get("ranking")
    stage = "search"
    if conf and conf["status"] == "done" and conf.get("ranking"):
        ranking, stage = conf["ranking"], "confirm"
    by_key = {p["key"]: p for p in pts}

    def entry(p):
        return {"job_id": p["job_ids"][0], "trial_number": p["trial_number"], "params": p["params"],
                "run_id": p["run_ids"][0] if p["run_ids"] else None, "stage": p["stage"],
                "objectives": {m: p["mean"].get(m) for m in metrics}, "sem": {m: p["sem"].get(m) for m in metrics},
                "sd": {m: p["sd"].get(m) for m in metrics}, "n": {m: p["n"].get(m) for m in metrics},
                "replicas": p["replicas"], "replicas_ok": p["replicas_ok"]}

    if len(metrics) == 1:
        if not ranking or ranking["best"] not in by_key:
            return []
        e = entry(by_key[ranking["best"]])
        e["tied"] = [entry(by_key[k]) for k in ranking["tied"] if k in by_key]
        e["confirmed"] = stage == "confirm"
        return [e]
    return [entry(p) for p in pts if p["stage"] == "search" and p.get("on_pareto_front")]


def points_page(s, study: Study, stage: str | None, limit: int, offset: int) -> dict[str, Any]:
    pts, conclusions = study_points(s, study)
    if stage:
        pts = [p for p in pts if p["stage"] == stage]
    return {"total": len(pts), "offset": offset, "limit": limit, "points": pts[offset:offset + limit],
            "ranking": conclusions.get("ranking")}


def trials_csv(rows: list[dict]) -> str:
    params = sorted({k for r in rows for k in r["params"]})
    metrics = sorted({k for r in rows for k, v in (r["metrics"] or {}).items() if not isinstance(v, (dict, list))})
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["job_id", "index", "trial_number", "status", "run_status", "run_id", "cached", *params, *metrics])
    for r in rows:
        m = r["metrics"] or {}
        w.writerow([r["job_id"], r["index"], r["trial_number"], r["status"], r["run_status"], r["run_id"], r["cached"],
                    *[r["params"].get(p) for p in params], *[m.get(k) for k in metrics]])
    return buf.getvalue()


def points_csv(pts: list[dict]) -> str:
    """One row per trial and stage: parameters, replicas, and per metric mean, sd, sem, n."""
    params = sorted({k for p in pts for k in p["params"]})
    metrics = sorted({m for p in pts for m, v in (p.get("mean") or {}).items() if v is not None})
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["key", "stage", "trial_number", "status", "replicas", "replicas_ok", "rank", "best", "tied", *params,
                *[f"{m}_{x}" for m in metrics for x in ("mean", "sd", "sem", "n")]])
    for p in pts:
        w.writerow([p["key"], p["stage"], p["trial_number"], p["status"], p["replicas"], p["replicas_ok"], p.get("rank"),
                    bool(p.get("best")), bool(p.get("tied")), *[p["params"].get(k) for k in params],
                    *[(p.get(x) or {}).get(m) for m in metrics for x in ("mean", "sd", "sem", "n")]])
    return buf.getvalue()
