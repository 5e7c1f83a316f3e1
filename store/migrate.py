"""Apply the Alembic migrations in ``store/migrations`` to a database URL.

Safe when several processes start together: PostgreSQL migrates under an advisory lock,
SQLite under an exclusive file lock next to the database file.
"""

from __future__ import annotations

import contextlib
import fcntl
from pathlib import Path

from alembic import command
from alembic.config import Config

from .sql import get_database

MIGRATIONS = Path(__file__).resolve().parent / "migrations"
_PG_LOCK_KEY = 0x46494252  # "FIBR"


def alembic_config(connection) -> Config:
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    cfg.attributes["connection"] = connection
    return cfg


@contextlib.contextmanager
def _sqlite_file_lock(url: str):
    path = url.split("///", 1)[-1]
    if path in ("", ":memory:"):
        yield
        return
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path + ".migrate-lock", "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def upgrade(url: str, revision: str = "head") -> None:
    import logging

    logging.getLogger("alembic").setLevel(logging.WARNING)
    db = get_database(url)
    if db.sqlite:
        with _sqlite_file_lock(db.url):
            # alembic runs its own transaction; use a plain connection (no BEGIN IMMEDIATE hook needed)
            with db.engine.connect() as conn:
                command.upgrade(alembic_config(conn), revision)
                conn.commit()
    else:
        with db.engine.connect() as conn:
            conn.exec_driver_sql(f"SELECT pg_advisory_lock({_PG_LOCK_KEY})")
            try:
                command.upgrade(alembic_config(conn), revision)
                conn.commit()
            finally:
                conn.exec_driver_sql(f"SELECT pg_advisory_unlock({_PG_LOCK_KEY})")
                conn.commit()
