"""What the store, the API and the workers read from the environment alike: the data folder's
default, the embedded SQLite database in it, and every job's wall-time cap."""

from __future__ import annotations

import os
from pathlib import Path

DEFAULT_DATA_DIR = "fibrecut-data"


def sqlite_url(data_dir: Path | str) -> str:
    """The embedded default database: SQLite in the data folder."""
    return f"sqlite:///{(Path(data_dir).resolve() / 'fibrecut.db').as_posix()}"


def max_job_wall_time_s(default: float = 86400.0) -> float:
    """FIBRECUT_MAX_JOB_WALL_TIME_S: every job's wall-time cap (a day unless set to a positive number)."""
    try:
        v = float(os.environ.get("FIBRECUT_MAX_JOB_WALL_TIME_S") or default)
    except ValueError:
        return default
    return v if v > 0 else default
