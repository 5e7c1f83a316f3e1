"""The store on SQLAlchemy: SQLite (embedded default, WAL) and PostgreSQL (scaled out), one code
path (:mod:`store.db` for engines and sessions, :mod:`store.queue` for the queue's statements,
:mod:`store.studies` for the driver)."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import sqlalchemy as sa
import sqlalchemy.exc

from . import driver, queue, studies
from .base import Claim, NewJob, Store
from .db import Database, normalize_url
from .models import Job, Run, Study, Worker
from .stages import driven


class SqlStore(Database, Store):
    """:class:`store.base.Store` on one database URL."""

    unavailable = (sa.exc.OperationalError,)

    def migrate(self) -> None:
        from .migrate import upgrade

        upgrade(self.url)

    # ------------------------------------------------------------------ workers
    def register_worker(self, worker_id: str) -> None:
        queue.register_worker(self, worker_id)

    def worker_stopped(self, worker_id: str) -> None:
        queue.worker_stopped(self, worker_id)

    def reap_lost_workers(self, data_dir: Path | str) -> dict[str, int]:
        return queue.clean_dead_workers(self, data_dir)

    def clean_orphan_run_files(self, data_dir: Path | str, min_age_s: float = 3600.0) -> int:
        return queue.clean_orphan_run_files(self, data_dir, min_age_s)

    def workers(self, limit: int = 1000) -> list[Any]:
        with self.read() as s:
            return list(s.execute(sa.select(Worker).order_by(Worker.started_at.desc()).limit(limit)).scalars())

    # ------------------------------------------------------------------ queue
    def enqueue_study(self, *, name: str, kind: str, document: dict[str, Any], planned_jobs: int, max_attempts: int,
                      jobs: list[NewJob]) -> int:
        t = time.time()
        with self.write() as s:
            st = Study(name=name, kind=kind, status="queued", document=document, planned_jobs=planned_jobs, created_at=t, updated_at=t)
            s.add(st)
            s.flush()
            s.add_all([Job(study_id=st.id, index=j.index, params=j.params, scene=j.scene, scene_hash=j.scene_hash,
                           status="queued", attempts=0, max_attempts=max_attempts, cancel_requested=False, progress=0.0,
                           cached=False, told=False, created_at=t) for j in jobs])
            return st.id

    def claim(self, worker_id: str, lease_s: float, solver_version: str) -> Claim | None:
        return queue.claim(self, worker_id, lease_s, solver_version)

    def heartbeat(self, claim: Claim, worker_id: str, lease_s: float, progress: float | None = None,
                  eta_s: float | None = None, message: str | None = None) -> str:
        return queue.heartbeat(self, claim, worker_id, lease_s, progress, eta_s, message)

    def finish(self, claim: Claim, worker_id: str, **run) -> bool:
        return queue.complete(self, claim, worker_id, **run)

    def fail(self, claim: Claim, worker_id: str, error: str) -> bool:
        return queue.fail(self, claim, worker_id, error)

    def release(self, claim: Claim, worker_id: str) -> bool:
        return queue.release(self, claim, worker_id)

    def cancel(self, study_id: int) -> bool:
        return queue.cancel_study(self, study_id)

    def queue_counts(self) -> dict[str, int]:
        with self.read() as s:
            rows = s.execute(sa.select(Job.status, sa.func.count()).where(Job.status.in_(("queued", "running")))
                             .group_by(Job.status)).all()
        return {"queued": 0, "running": 0, **dict(rows)}

    # ------------------------------------------------------------------ studies
    def is_driven(self, study_id: int) -> bool:
        with self.read() as s:
            st = s.get(Study, study_id)
            return bool(st and driven(st.kind, st.document))

    def start_trials(self, study_id: int, document: Any) -> None:
        driver.create_optuna_study(self, study_id, document, "search")

    def drive(self, study_id: int, owner: str | None = None) -> None:
        studies.drive(self, study_id, owner)

    def drive_all(self, owner: str | None = None) -> None:
        studies.drive_all(self, owner)

    # ------------------------------------------------------------------ results
    def run(self, run_id: str) -> Any | None:
        with self.read() as s:
            return s.get(Run, run_id)


_cache: dict[str, SqlStore] = {}
_lock = threading.Lock()


def get_database(url: str) -> SqlStore:
    """The store of a database URL (one per URL and process)."""
    url = normalize_url(url)
    with _lock:
        if url not in _cache:
            _cache[url] = SqlStore(url)
        return _cache[url]


def forget_databases() -> None:
    """Drop cached engines (after a fork, or between tests)."""
    with _lock:
        for d in _cache.values():
            d.dispose()
        _cache.clear()
