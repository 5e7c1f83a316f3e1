"""Service settings: the database URL, the data folder, the API token and the input limits.

One place reads the environment (``FIBRECUT_*``; :mod:`store.config` for what the workers
read alike); everything else receives a :class:`Settings`. The data folder holds the SQLite database of the embedded default and
``runs/<run id>.h5``: the only files the service ever serves.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from store.config import DEFAULT_DATA_DIR, max_job_wall_time_s, sqlite_url


@dataclass
class Limits:
    """Guards against runaway studies and oversized requests (HTTP 413/422 beyond them)."""

    max_body_bytes: int = 1_000_000
    max_jobs_per_study: int = 5000
    max_values_per_parameter: int = 1000
    max_parameters: int = 16
    max_n_trials: int = 5000
    max_parallelism: int = 256
    max_objectives: int = 4
    max_constraints: int = 8
    max_studies_listed: int = 1000
    # elements, particles and memory of one job's scene (solver.budget.Limits; FIBRECUT_MAX_* override)
    scene: Any = field(default_factory=lambda: _scene_limits())
    # a job's wall time: numerics.max_wall_time_s, at most this (FIBRECUT_MAX_JOB_WALL_TIME_S)
    max_job_wall_time_s: float = field(default_factory=lambda: max_job_wall_time_s())


def _scene_limits():
    from solver.budget import Limits as SceneLimits

    return SceneLimits.from_env()


@dataclass
class Settings:
    data_dir: Path = field(default_factory=lambda: Path(DEFAULT_DATA_DIR))
    db_url: str | None = None  # default: SQLite in the data folder
    api_token: str | None = None
    lease_s: float = 30.0  # a worker's claim on a job; renewed every lease_s / 3 by the heartbeat
    limits: Limits = field(default_factory=Limits)

    def __post_init__(self):
        self.data_dir = Path(self.data_dir)
        if not self.db_url:
            self.db_url = sqlite_url(self.data_dir)

    @property
    def runs_dir(self) -> Path:
        return self.data_dir / "runs"

    @classmethod
    def from_env(cls, **overrides) -> "Settings":
        kw = {
            "data_dir": Path(os.environ.get("FIBRECUT_DATA", DEFAULT_DATA_DIR)),
            "db_url": os.environ.get("FIBRECUT_DB") or None,
            "api_token": os.environ.get("FIBRECUT_API_TOKEN") or None,
            "lease_s": float(os.environ.get("FIBRECUT_LEASE_S", "30")),
        }
        kw.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**kw)
