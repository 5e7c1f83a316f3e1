"""SQLAlchemy models: studies, jobs, runs, workers.

Table names carry the ``fc_`` prefix because optuna's RDB storage lives in the same
database and owns ``studies``, ``trials`` and ``alembic_version``. Times are UNIX seconds
(float) from the writer's clock: the same on SQLite and PostgreSQL (keep hosts on NTP).
The schema is created by the Alembic migrations in ``store/migrations``; keep the two in
step (tests/test_service_api.py compares them).
"""

from __future__ import annotations

from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

STUDY_STATES = ("queued", "running", "done", "failed", "cancelled")
JOB_STATES = ("queued", "running", "done", "failed", "cancelled")
TERMINAL_JOB_STATES = ("done", "failed", "cancelled")


class Base(DeclarativeBase):
    type_annotation_map = {dict[str, Any]: sa.JSON, list[Any]: sa.JSON}


class Study(Base):
    __tablename__ = "fc_studies"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(sa.String(200))
    kind: Mapped[str] = mapped_column(sa.String(20))
    status: Mapped[str] = mapped_column(sa.String(20), default="queued", index=True)
    document: Mapped[dict[str, Any]] = mapped_column(sa.JSON)
    planned_jobs: Mapped[int] = mapped_column(default=0)  # sweep/convergence: design size; optimize: n_trials
    error: Mapped[str | None] = mapped_column(sa.Text, default=None)
    created_at: Mapped[float] = mapped_column(sa.Float)
    updated_at: Mapped[float] = mapped_column(sa.Float)
    finished_at: Mapped[float | None] = mapped_column(sa.Float, default=None)
    # optimisation driver lease: one process at a time asks and tells optuna for this study
    driver_owner: Mapped[str | None] = mapped_column(sa.String(64), default=None)
    driver_until: Mapped[float | None] = mapped_column(sa.Float, default=None)


class Job(Base):
    __tablename__ = "fc_jobs"
    __table_args__ = (sa.Index("ix_fc_jobs_claim", "status", "lease_until", "id"),
                      sa.UniqueConstraint("study_id", "index", name="uq_fc_jobs_study_index"))

    id: Mapped[int] = mapped_column(primary_key=True)
    study_id: Mapped[int] = mapped_column(sa.ForeignKey("fc_studies.id", ondelete="CASCADE"), index=True)
    index: Mapped[int] = mapped_column()  # position in the study (design point or trial order)
    trial_number: Mapped[int | None] = mapped_column(default=None)  # optuna trial number (optimize)
    params: Mapped[dict[str, Any]] = mapped_column(sa.JSON)  # the study's parameters for this job
    scene: Mapped[dict[str, Any]] = mapped_column(sa.JSON)  # the full validated scene (user units)
    scene_hash: Mapped[str] = mapped_column(sa.String(64), index=True)
    status: Mapped[str] = mapped_column(sa.String(20), default="queued")
    attempts: Mapped[int] = mapped_column(default=0)  # claims so far; also the fencing token
    max_attempts: Mapped[int] = mapped_column(default=3)
    lease_owner: Mapped[str | None] = mapped_column(sa.String(64), default=None)
    lease_until: Mapped[float | None] = mapped_column(sa.Float, default=None)
    cancel_requested: Mapped[bool] = mapped_column(default=False)
    progress: Mapped[float] = mapped_column(sa.Float, default=0.0)
    eta_s: Mapped[float | None] = mapped_column(sa.Float, default=None)
    message: Mapped[str | None] = mapped_column(sa.String(500), default=None)
    run_id: Mapped[str | None] = mapped_column(sa.String(32), sa.ForeignKey("fc_runs.id"), default=None)
    cached: Mapped[bool] = mapped_column(default=False)
    error: Mapped[str | None] = mapped_column(sa.Text, default=None)
    told: Mapped[bool] = mapped_column(default=False)  # optimize: the outcome was told to optuna
    created_at: Mapped[float] = mapped_column(sa.Float)
    started_at: Mapped[float | None] = mapped_column(sa.Float, default=None)
    finished_at: Mapped[float | None] = mapped_column(sa.Float, default=None)


class Run(Base):
    """One solver run and its HDF5 file ``runs/<id>.h5`` (written by the worker that ran it)."""

    __tablename__ = "fc_runs"

    id: Mapped[str] = mapped_column(sa.String(32), primary_key=True)  # uuid4 hex
    job_id: Mapped[int | None] = mapped_column(default=None)  # the job that computed it
    scene_hash: Mapped[str] = mapped_column(sa.String(64), index=True)
    solver_version: Mapped[str] = mapped_column(sa.String(40))
    status: Mapped[str] = mapped_column(sa.String(20))  # ok | unstable | failed | cancelled
    summary: Mapped[dict[str, Any]] = mapped_column(sa.JSON)
    diagnosis: Mapped[dict[str, Any] | None] = mapped_column(sa.JSON, default=None)
    wall_time_s: Mapped[float] = mapped_column(sa.Float, default=0.0)
    has_file: Mapped[bool] = mapped_column(default=False)
    worker_id: Mapped[str | None] = mapped_column(sa.String(64), default=None)
    host: Mapped[str | None] = mapped_column(sa.String(200), default=None)
    created_at: Mapped[float] = mapped_column(sa.Float)


class Worker(Base):
    __tablename__ = "fc_workers"

    id: Mapped[str] = mapped_column(sa.String(64), primary_key=True)
    host: Mapped[str] = mapped_column(sa.String(200))
    pid: Mapped[int] = mapped_column()
    started_at: Mapped[float] = mapped_column(sa.Float)
    last_seen: Mapped[float] = mapped_column(sa.Float)
    jobs_done: Mapped[int] = mapped_column(default=0)
    current_job_id: Mapped[int | None] = mapped_column(default=None)
    status: Mapped[str] = mapped_column(sa.String(20), default="idle")  # idle | busy | stopped | lost (heartbeat expired or process gone)
