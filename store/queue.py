"""The job queue in the database: atomic claim, leases renewed by heartbeat, fencing, cancel.

One code path for both databases. A claim is one ``UPDATE ... WHERE id = (SELECT ... LIMIT 1
FOR UPDATE SKIP LOCKED) RETURNING``: on PostgreSQL concurrent claimers skip each other's
locked rows; on SQLite the statement runs inside ``BEGIN IMMEDIATE`` (single writer, WAL,
busy_timeout) and SQLAlchemy leaves the locking clause out.

The attempt counter is the fencing token: a worker may renew, finish or fail a job only while
``attempts`` still equals the value its claim returned and the job is ``running``. A worker
that lost its lease (it stalled, or was presumed dead and the job was claimed again) finds
that its heartbeat or its completion matches no row; it then discards its result and its
file, so a job has exactly one result even when two workers ran it.
"""

from __future__ import annotations

import socket
import time
from typing import Any

import sqlalchemy as sa

from solver.warmup import pid_alive

from .base import Claim
from .db import Database
from .models import TERMINAL_JOB_STATES, Job, Run, Study, Worker
from .stages import driven


def now() -> float:
    return time.time()


REAP_EVERY_S = 1.0  # how often one process looks for expired leases (a claim finds claimable expired jobs anyway)
_last_reap = [0.0]


# ------------------------------------------------------------------ workers
def register_worker(db: Database, worker_id: str) -> None:
    import os

    t = now()
    with db.write() as s:
        s.merge(Worker(id=worker_id, host=socket.gethostname()[:200], pid=os.getpid(), started_at=t, last_seen=t,
                       jobs_done=0, status="idle"))


LOST_AFTER_S = 120.0  # a worker not seen for this long is lost (it heartbeats every lease/3, polls every 2 s)


def worker_state(w, t: float, host: str | None = None) -> str:
    """A worker row's state as the dashboard shows it: ``lost`` when its heartbeat expired or
    (on this host) its process is gone; else its own ``idle``, ``busy``, ``stopped`` or ``lost``."""
    if w.status in ("stopped", "lost"):
        return w.status
    if w.last_seen < t - LOST_AFTER_S:
        return "lost"
    if host is not None and w.host == host and not pid_alive(w.pid):
        return "lost"
    return w.status


def clean_dead_workers(db: Database, data_dir) -> dict[str, int]:
    """Mark dead workers ``lost`` and clean what they left in the data folder: a result file
    whose run row was committed moves into ``runs/``, any other is deleted. Called by every
    worker and by the server at start-up. Returns counts (lost, moved, deleted)."""
    import os
    import shutil
    from pathlib import Path

    t = now()
    host = socket.gethostname()[:200]
    with db.read() as s:
        rows = s.execute(sa.select(Worker)).scalars().all()
    states = {w.id: worker_state(w, t, host) for w in rows}
    newly_lost = [w.id for w in rows if states[w.id] == "lost" and w.status != "lost"]
    if newly_lost:
        with db.write() as s:
            s.execute(sa.update(Worker).where(Worker.id.in_(newly_lost), Worker.status.not_in(("stopped", "lost")))
                      .values(status="lost", current_job_id=None))
    moved = deleted = 0
    root = Path(data_dir) / "partial"
    runs = Path(data_dir) / "runs"
    if root.is_dir():
        for d in root.iterdir():
            if not d.is_dir() or states.get(d.name) not in (None, "stopped", "lost"):
                continue  # a live worker's files
            files = [f for f in d.iterdir() if f.is_file()]
            ids = [f.stem for f in files if len(f.stem) == 32 and f.suffix == ".h5"]
            with db.read() as s:
                committed = set(s.execute(sa.select(Run.id).where(Run.id.in_(ids), Run.has_file)).scalars()) if ids else set()
            for f in files:
                try:
                    if f.suffix == ".h5" and f.stem in committed:
                        runs.mkdir(parents=True, exist_ok=True)
                        os.replace(f, runs / f.name)
                        moved += 1
                    else:
                        f.unlink()
                        deleted += 1
                except FileNotFoundError:
                    pass
            shutil.rmtree(d, ignore_errors=True)
    return {"lost": len(newly_lost), "moved": moved, "deleted": deleted}


def clean_orphan_run_files(db: Database, data_dir, min_age_s: float = 3600.0) -> int:
    """Delete files in ``runs/`` that no run row names and that are older than ``min_age_s``
    (left by workers that wrote there directly and died before their commit, or half-written
    temporaries). Called by the server at start-up; returns how many it deleted."""
    from pathlib import Path

    runs = Path(data_dir) / "runs"
    if not runs.is_dir():
        return 0
    t = now()
    old = []
    for f in runs.iterdir():
        try:
            if f.is_file() and f.suffix == ".h5" and t - f.stat().st_mtime > min_age_s:
                old.append(f)
        except FileNotFoundError:
            continue
    deleted = 0
    for i in range(0, len(old), 500):
        chunk = old[i:i + 500]
        with db.read() as s:
            known = set(s.execute(sa.select(Run.id).where(Run.id.in_([f.stem for f in chunk]))).scalars())
        for f in chunk:
            if f.stem not in known:
                try:
                    f.unlink()
                    deleted += 1
                except FileNotFoundError:
                    pass
    return deleted


def worker_stopped(db: Database, worker_id: str) -> None:
    with db.write() as s:
        s.execute(sa.update(Worker).where(Worker.id == worker_id).values(status="stopped", last_seen=now(), current_job_id=None))


# ------------------------------------------------------------------ reaping expired leases
def reap_expired(s, t: float) -> list[int]:
    """Jobs whose lease expired: cancel those asked to stop, fail those out of attempts.

    The rest (attempts left) are claimable again by :func:`claim`. Returns the study ids touched.
    """
    expired = (Job.status == "running") & (Job.lease_until < t)
    touched = set()
    rows = s.execute(sa.update(Job).where(expired & Job.cancel_requested).values(
        status="cancelled", finished_at=t, lease_owner=None, error="cancelled; the worker was lost").returning(Job.study_id)).all()
    touched.update(r[0] for r in rows)
    rows = s.execute(sa.update(Job).where(expired & (Job.attempts >= Job.max_attempts)).values(
        status="failed", finished_at=t, lease_owner=None,
        error="the lease expired on every attempt (worker lost or stalled); max_attempts reached"
    ).returning(Job.study_id)).all()
    touched.update(r[0] for r in rows)
    return sorted(touched)


# ------------------------------------------------------------------ claim
def claim(db: Database, worker_id: str, lease_s: float, solver_version: str) -> Claim | None:
    """Claim the oldest claimable job, or None. Cache hits are finished here, never returned."""
    while True:
        t = now()
        with db.write() as s:
            if t - _last_reap[0] > REAP_EVERY_S:
                _last_reap[0] = t
                for sid in reap_expired(s, t):
                    _finish_study_if_complete(s, sid, t)
            claimable = (Job.status == "queued") | (
                (Job.status == "running") & (Job.lease_until < t) & (Job.attempts < Job.max_attempts) & ~Job.cancel_requested)
            pick = (sa.select(Job.id).where(claimable).order_by(Job.id).limit(1)
                    .with_for_update(skip_locked=True).scalar_subquery())
            row = s.execute(sa.update(Job).where(Job.id == pick).where(claimable).values(
                status="running", attempts=Job.attempts + 1, lease_owner=worker_id, lease_until=t + lease_s,
                started_at=t, progress=0.0, eta_s=None, message="claimed", error=None,
            ).returning(Job.id, Job.study_id, Job.attempts, Job.scene, Job.scene_hash, Job.params)).first()
            if row is None:
                s.execute(sa.update(Worker).where(Worker.id == worker_id).values(last_seen=t, status="idle", current_job_id=None))
                return None
            c = Claim(job_id=row[0], study_id=row[1], attempt=row[2], scene=row[3], scene_hash=row[4], params=row[5])
            s.execute(sa.update(Worker).where(Worker.id == worker_id).values(last_seen=t, status="busy", current_job_id=c.job_id))
            s.execute(sa.update(Study).where(Study.id == c.study_id, Study.status == "queued").values(status="running", updated_at=t))
            cached = s.execute(sa.select(Run.id).where(Run.scene_hash == c.scene_hash, Run.solver_version == solver_version,
                                                       Run.status == "ok", Run.has_file).order_by(Run.created_at).limit(1)).scalar()
            if cached is None:
                return c
            # result cache: the same canonical scene was already computed by this solver version
            s.execute(sa.update(Job).where(Job.id == c.job_id).values(
                status="done", run_id=cached, cached=True, progress=1.0, eta_s=0.0, finished_at=t, lease_owner=None,
                message="cached"))
            _finish_study_if_complete(s, c.study_id, t)


# ------------------------------------------------------------------ heartbeat
def heartbeat(db: Database, c: Claim, worker_id: str, lease_s: float, progress: float | None = None,
              eta_s: float | None = None, message: str | None = None) -> str:
    """Renew the lease and store progress. Returns ``ok``, ``cancel`` (stop the run) or ``lost``."""
    t = now()
    values: dict[str, Any] = {"lease_until": t + lease_s}
    if progress is not None:
        values["progress"] = max(0.0, min(1.0, float(progress)))
    if eta_s is not None:
        values["eta_s"] = float(eta_s)
    if message is not None:
        values["message"] = message[:500]
    with db.write() as s:
        row = s.execute(sa.update(Job).where(Job.id == c.job_id, Job.attempts == c.attempt, Job.status == "running",
                                             Job.lease_owner == worker_id)
                        .values(**values).returning(Job.cancel_requested)).first()
        s.execute(sa.update(Worker).where(Worker.id == worker_id).values(last_seen=t))
    if row is None:
        return "lost"
    return "cancel" if row[0] else "ok"


# ------------------------------------------------------------------ completion
def complete(db: Database, c: Claim, worker_id: str, *, run_id: str, run_status: str, summary: dict, diagnosis: dict | None,
             wall_time_s: float, solver_version: str, has_file: bool) -> bool:
    """Record the run and finish the job, fenced by the claim's attempt. False: the lease was lost."""
    t = now()
    job_status = {"ok": "done", "cancelled": "cancelled"}.get(run_status, "failed")
    error = None
    if job_status == "failed":
        d = diagnosis or {}
        error = f"run {run_status}: " + str(d.get("what") or d.get("check") or "see the run's diagnosis")
    try:
        _complete(db, c, worker_id, t, job_status, error, run_id, run_status, summary, diagnosis, wall_time_s, solver_version, has_file)
    except _LeaseLost:
        return False
    return True


class _LeaseLost(Exception):
    pass


def _complete(db, c, worker_id, t, job_status, error, run_id, run_status, summary, diagnosis, wall_time_s, solver_version, has_file):
    with db.write() as s:
        s.add(Run(id=run_id, job_id=c.job_id, scene_hash=c.scene_hash, solver_version=solver_version, status=run_status,
                  summary=summary, diagnosis=diagnosis, wall_time_s=float(wall_time_s), has_file=has_file, worker_id=worker_id,
                  host=socket.gethostname()[:200], created_at=t))
        s.flush()
        n = s.execute(sa.update(Job).where(Job.id == c.job_id, Job.attempts == c.attempt, Job.status == "running",
                                           Job.lease_owner == worker_id)
                      .values(status=job_status, lease_owner=None, finished_at=t, progress=1.0 if job_status == "done" else Job.progress,
                              eta_s=0.0, message=f"run {run_status}", error=error, run_id=run_id)).rowcount
        if n != 1:
            raise _LeaseLost  # rolls the run back too
        s.execute(sa.update(Worker).where(Worker.id == worker_id).values(
            last_seen=t, status="idle", current_job_id=None, jobs_done=Worker.jobs_done + 1))
        _finish_study_if_complete(s, c.study_id, t)


def fail(db: Database, c: Claim, worker_id: str, error: str) -> bool:
    """Finish the job as failed without a run (the worker could not even start the solver)."""
    t = now()
    with db.write() as s:
        n = s.execute(sa.update(Job).where(Job.id == c.job_id, Job.attempts == c.attempt, Job.status == "running",
                                           Job.lease_owner == worker_id)
                      .values(status="failed", lease_owner=None, finished_at=t, error=error[:4000])).rowcount
        if n == 1:
            _finish_study_if_complete(s, c.study_id, t)
    return n == 1


# ------------------------------------------------------------------ cancellation
def cancel_study(db: Database, study_id: int) -> bool:
    """Cancel queued jobs now; flag running ones (their workers stop at the next heartbeat)."""
    t = now()
    with db.write() as s:
        st = s.get(Study, study_id)
        if st is None:
            return False
        s.execute(sa.update(Job).where(Job.study_id == study_id, Job.status == "queued").values(
            status="cancelled", finished_at=t, message="cancelled before it ran"))
        s.execute(sa.update(Job).where(Job.study_id == study_id, Job.status == "running").values(cancel_requested=True))
        if st.status not in ("done", "failed", "cancelled"):
            st.status = "cancelled"
            st.finished_at = t
        st.updated_at = t
    return True


# ------------------------------------------------------------------ study status
def _finish_study_if_complete(s, study_id: int, t: float) -> None:
    """A sweep or convergence study ends when its last job ends (optimize, calibrate and studies
    with a confirmation stage: their driver decides).

    The study row is locked (FOR UPDATE; SQLite has one writer anyway) before the open jobs are
    counted: under READ COMMITTED two workers finishing the last two jobs at once would each
    see the other's job still running and neither would close the study. The lock is held
    only until this short transaction commits.
    """
    s.execute(sa.select(Study.id).where(Study.id == study_id).with_for_update())
    open_jobs = s.execute(sa.select(sa.func.count()).select_from(Job).where(
        Job.study_id == study_id, Job.status.not_in(TERMINAL_JOB_STATES))).scalar()
    if open_jobs:
        return
    st = s.get(Study, study_id)
    if st is None or st.status in ("done", "failed", "cancelled"):
        return
    st.updated_at = t
    if driven(st.kind, st.document):  # its driver runs the next stage or ends it
        return
    n_done = s.execute(sa.select(sa.func.count()).select_from(Job).where(Job.study_id == study_id, Job.status == "done")).scalar()
    st.status = "done" if n_done else "failed"
    if not n_done:
        st.error = "no job of the study finished successfully"
    st.finished_at = t


def counts(s, study_id: int) -> dict[str, int]:
    return counts_and_progress(s, study_id)[0]


def counts_and_progress(s, study_id: int) -> tuple[dict[str, int], float, float | None]:
    """Jobs by state (+ cached), the summed progress of running jobs, the first start: one query."""
    out = {k: 0 for k in ("queued", "running", "done", "failed", "cancelled")}
    out["cached"] = 0
    running_progress, first_start = 0.0, None
    rows = s.execute(sa.select(Job.status, sa.func.count(), sa.func.sum(sa.case((Job.cached, 1), else_=0)),
                               sa.func.sum(Job.progress), sa.func.min(Job.started_at))
                     .where(Job.study_id == study_id).group_by(Job.status))
    for status, n, n_cached, progress, started in rows:
        out[status] = n
        out["cached"] += int(n_cached or 0)
        if status == "running":
            running_progress = float(progress or 0.0)
        if started is not None:
            first_start = started if first_start is None else min(first_start, started)
    return out, running_progress, first_start


def release(db: Database, c: Claim, worker_id: str) -> bool:
    """Give a claimed job back to the queue (a worker shutting down): not counted as an attempt."""
    with db.write() as s:
        n = s.execute(sa.update(Job).where(Job.id == c.job_id, Job.attempts == c.attempt, Job.status == "running",
                                           Job.lease_owner == worker_id)
                      .values(status="queued", lease_owner=None, lease_until=None, attempts=Job.attempts - 1,
                              progress=0.0, eta_s=None, message="released by a worker that stopped")).rowcount
        s.execute(sa.update(Worker).where(Worker.id == worker_id).values(current_job_id=None, status="idle"))
    return n == 1
