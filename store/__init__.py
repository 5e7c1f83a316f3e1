"""The store: the job queue, the studies and the results behind one contract
(:class:`store.base.Store`), implemented on SQLAlchemy for SQLite and PostgreSQL
(:class:`store.sql.SqlStore`). The API and the workers depend on it; it depends only on the solver.

``get_database(url)`` answers the store of a URL (one per URL and process).
"""

from .base import Claim, NewJob, Store
from .config import DEFAULT_DATA_DIR, max_job_wall_time_s, sqlite_url
from .sql import SqlStore, forget_databases, get_database

__all__ = ["Claim", "DEFAULT_DATA_DIR", "NewJob", "SqlStore", "Store", "forget_databases", "get_database",
           "max_job_wall_time_s", "sqlite_url"]
