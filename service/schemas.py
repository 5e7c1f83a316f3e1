"""Pydantic schemas of the REST API's answers; the study document a client submits is
:class:`store.documents.StudyIn` (docs/studies.md)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, Field, create_model

from store.models import JOB_STATES

#: a study's jobs by state, and how many of the done ones came from the result cache
JobCounts = create_model("JobCounts", **{k: (int, 0) for k in (*JOB_STATES, "cached")})


class StudyOut(BaseModel):
    id: int
    name: str
    kind: str
    status: Literal["queued", "running", "done", "failed", "cancelled"]
    counts: JobCounts
    planned_jobs: int
    progress: float = Field(description="fraction of the planned jobs finished, plus running jobs' progress")
    eta_s: float | None = None
    created_at: float
    updated_at: float
    finished_at: float | None = None
    error: str | None = None
    document: dict[str, Any] | None = None
    best: list[dict[str, Any]] | None = Field(None, description="optimize: best trial, or the Pareto front for several objectives; "
                                             "with replicas the means, their standard errors and the statistically tied trials")
    ranking: dict[str, Any] | None = Field(None, description="one objective: the trials ranked by their mean, the best with its "
                                                            "standard error and the trials within two combined standard errors of it")
    confirmation: dict[str, Any] | None = Field(None, description="confirm: the best trials re-run, ranked again by their confirmed means")
    screening: dict[str, Any] | None = Field(None, description="screen: the refinement box and how far the two fidelities agree on the shared points")
    calibration: dict[str, Any] | None = Field(None, description="calibrate: fitted values (dotted names), misfit, per_point residuals, loo_error, preset")


class TrialOut(BaseModel):
    job_id: int
    index: int
    trial_number: int | None
    params: dict[str, Any]
    metrics: dict[str, Any] | None
    status: str
    run_status: str | None
    run_id: str | None
    cached: bool
    attempts: int
    progress: float
    eta_s: float | None
    message: str | None
    error: str | None
    wall_time_s: float | None
    on_pareto_front: bool | None = Field(None, description="optimize: non-dominated and feasible (one objective: the best)")
    feasible: bool | None = Field(None, description="optimize: every constraint met")
    reference_job_id: int | None = Field(None, description="convergence: the finest finished level")
    error_vs_finest: dict[str, float] | None = Field(None, description="convergence: relative error of each metric against the finest level (with replicas: of the level's mean against the finest level's mean)")
    error_uncertainty: dict[str, float] | None = Field(None, description="convergence with replicas: the standard error of that error (of the difference of the two means, relative to the finest mean)")
    stage: str = Field("search", description="search, screen (the cheap fidelity's search), check (a refined trial at the screening fidelity) or confirm")
    aggregate: dict[str, Any] | None = Field(None, description="with replicas or stages: the trial's replicas (ok ones), mean, sd, sem and n of each metric")
    tied: bool | None = Field(None, description="one objective: within two combined standard errors of the best trial")
    level: dict[str, Any] | None = Field(None, description="convergence with replicas: the trial's level (params without replica), its replicas (ok ones), mean, sd and standard error of each metric, mean wall time per run")


class PointsPage(BaseModel):
    total: int
    offset: int
    limit: int
    points: list[dict[str, Any]] = Field(description="one per trial and stage: params, stage, replicas, replicas_ok, mean, sd, sem, n, rank, best, tied")
    ranking: dict[str, Any] | None = None


class MeasurementsOut(BaseModel):
    measurements: list[dict[str, Any]]


class RunOut(BaseModel):
    id: str
    job_id: int | None
    status: str
    summary: dict[str, Any]
    diagnosis: dict[str, Any] | None
    wall_time_s: float
    solver_version: str
    host: str | None
    worker_id: str | None
    created_at: float
    has_file: bool
    estimated_discretisation_error: dict[str, Any] | None = Field(
        None, description="from the newest convergence study of the same scene (apart from the varied fields): "
                          "the relative error of each metric against its finest level, at this run's resolution")


class SceneOut(BaseModel):
    name: str
    description: str
    fidelity: str
    scene: dict[str, Any]


class Health(BaseModel):
    status: Literal["ok"]
    database: str
    solver_version: str
    workers_seen: int
    jobs_queued: int
    jobs_running: int
    workers_lost: int = Field(0, description="workers whose heartbeat expired (or whose process is gone) in the last hour")
    kernels: Literal["ready", "compiling", "cold"] = Field(
        "cold", description="the solver's numba kernels on this server: compiled (ready), being compiled once for the "
                            "installation (compiling), or not yet (cold: the first FEM run compiles them)")


class WorkerOut(BaseModel):
    id: str
    host: str
    pid: int
    status: Literal["idle", "busy", "stopped", "lost"]
    started_at: float
    last_seen: float
    jobs_done: int
    current_job_id: int | None = None
