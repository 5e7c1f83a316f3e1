"""The store's contract: every operation the workers, the API and the server need from the queue,
the studies and the results, in one abstract class (as optuna's ``BaseStorage`` is for its
storages). :class:`store.sql.SqlStore` implements it on SQLAlchemy for SQLite and PostgreSQL.

A job goes ``queued`` -> ``running`` (claimed, under a lease renewed by heartbeat) -> ``done``,
``failed`` or ``cancelled``. The claim's attempt number is its fencing token: a worker may renew,
finish or fail a job only while it still holds that attempt; a worker that lost its lease learns
it from :meth:`Store.heartbeat` (``lost``) or :meth:`Store.finish` (False) and drops its result.
"""

from __future__ import annotations

import abc
import uuid
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass
class Claim:
    """A job a worker holds: what to run, and the attempt that fences its writes."""

    job_id: int
    study_id: int
    attempt: int
    scene: dict[str, Any]
    scene_hash: str
    params: dict[str, Any]


@dataclass
class NewJob:
    """One job of a study being enqueued: its index, parameters, scene (user units) and scene hash."""

    index: int
    params: dict[str, Any]
    scene: dict[str, Any]
    scene_hash: str


class Store(abc.ABC):
    """The queue, the studies and the results behind one interface."""

    url: str
    #: the errors that mean the store is out of reach for now (a server restart, a dropped
    #: connection): the caller retries, and a job whose lease expires meanwhile is requeued
    unavailable: tuple[type[Exception], ...] = ()

    # ------------------------------------------------------------------ schema
    @abc.abstractmethod
    def migrate(self) -> None:
        """Create or upgrade the store's tables (safe when several processes start together)."""

    # ------------------------------------------------------------------ workers
    @abc.abstractmethod
    def register_worker(self, worker_id: str) -> None:
        """Record a worker that starts (host, pid, idle)."""

    @abc.abstractmethod
    def worker_stopped(self, worker_id: str) -> None:
        """Record a worker that stops on its own."""

    @abc.abstractmethod
    def reap_lost_workers(self, data_dir: Path | str) -> dict[str, int]:
        """Mark dead workers ``lost`` and clean what they left in ``data_dir/partial`` (a file
        whose run was committed moves into ``runs/``, any other is deleted). Counts (lost,
        moved, deleted)."""

    @abc.abstractmethod
    def clean_orphan_run_files(self, data_dir: Path | str, min_age_s: float = 3600.0) -> int:
        """Delete files in ``data_dir/runs`` that no run names and older than ``min_age_s``."""

    @abc.abstractmethod
    def workers(self, limit: int = 1000) -> list[Any]:
        """The worker rows, newest first (each with id, host, pid, status, started_at, last_seen,
        jobs_done, current_job_id); :func:`store.queue.worker_state` tells the dashboard's state."""

    # ------------------------------------------------------------------ queue
    @abc.abstractmethod
    def enqueue_study(self, *, name: str, kind: str, document: dict[str, Any], planned_jobs: int, max_attempts: int,
                      jobs: list[NewJob]) -> int:
        """Store a study and its first jobs (queued) in one transaction; answers the study's id."""

    @abc.abstractmethod
    def claim(self, worker_id: str, lease_s: float, solver_version: str) -> Claim | None:
        """The oldest claimable job under a lease of ``lease_s``, or None. A job whose scene this
        solver version already computed finishes from the result cache and is never returned."""

    @abc.abstractmethod
    def heartbeat(self, claim: Claim, worker_id: str, lease_s: float, progress: float | None = None,
                  eta_s: float | None = None, message: str | None = None) -> str:
        """Renew the lease and store the progress: ``ok``, ``cancel`` (stop the run) or ``lost``."""

    @abc.abstractmethod
    def finish(self, claim: Claim, worker_id: str, *, run_id: str, run_status: str, summary: dict,
               diagnosis: dict | None, wall_time_s: float, solver_version: str, has_file: bool) -> bool:
        """Record the run and end the job; False when the lease was lost (nothing recorded)."""

    @abc.abstractmethod
    def fail(self, claim: Claim, worker_id: str, error: str) -> bool:
        """End the job as failed without a run (the solver could not start)."""

    @abc.abstractmethod
    def release(self, claim: Claim, worker_id: str) -> bool:
        """Give a claimed job back to the queue (a worker shutting down; not an attempt)."""

    @abc.abstractmethod
    def cancel(self, study_id: int) -> bool:
        """Cancel a study: queued jobs at once, running ones at their next heartbeat. False: no such study."""

    @abc.abstractmethod
    def queue_counts(self) -> dict[str, int]:
        """Jobs queued and running over all studies."""

    # ------------------------------------------------------------------ studies
    @abc.abstractmethod
    def is_driven(self, study_id: int) -> bool:
        """Whether a driver moves the study forward (optimize, calibrate, a sweep with a confirmation)."""

    @abc.abstractmethod
    def start_trials(self, study_id: int, document: Any) -> None:
        """Create the optimiser's own study for an optimize or calibrate study (its metric names)."""

    @abc.abstractmethod
    def drive(self, study_id: int, owner: str | None = None) -> None:
        """Tell the optimiser what finished, ask for new trials, start the next stage or end the
        study. One driver at a time per study; idempotent and resumable."""

    @abc.abstractmethod
    def drive_all(self, owner: str | None = None) -> None:
        """One pass of the scheduler: drive every driven study that is not finished."""

    # ------------------------------------------------------------------ results
    @abc.abstractmethod
    def run(self, run_id: str) -> Any | None:
        """A run's record (id, job_id, status, summary, diagnosis, wall_time_s, has_file, ...), or None."""

    @abc.abstractmethod
    def read(self) -> AbstractContextManager[Any]:
        """A read transaction over the store's tables (:mod:`store.models`): the reports of the API."""

    # ------------------------------------------------------------------ files
    @staticmethod
    def new_run_id() -> str:
        """A new run's id: its file is ``<data>/runs/<id>.h5``."""
        return uuid.uuid4().hex

    @staticmethod
    def partial_dir(data_dir: Path | str, worker_id: str) -> Path:
        """Where a worker writes a run's file until its row is committed (then it moves to runs/)."""
        return Path(data_dir) / "partial" / worker_id
