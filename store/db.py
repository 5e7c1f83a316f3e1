"""Database engines and sessions for SQLite (embedded default) and PostgreSQL (scaled out).

SQLite: WAL mode, ``busy_timeout`` and every write transaction opened with
``BEGIN IMMEDIATE`` so writers queue on the database lock instead of failing on a lock
upgrade ("database is locked"). Reads (the API's GETs) use a second engine whose
transactions are deferred: in WAL mode readers never block writers nor wait for them.
PostgreSQL: plain READ COMMITTED; the queue claims jobs with ``FOR UPDATE SKIP LOCKED``.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

import sqlalchemy as sa
from sqlalchemy import event
from sqlalchemy.orm import Session, sessionmaker

SQLITE_BUSY_TIMEOUT_MS = 60_000


def normalize_url(url: str) -> str:
    """``postgresql://`` and ``postgres://`` use psycopg 3 (the driver we install)."""
    for prefix in ("postgresql://", "postgres://"):
        if url.startswith(prefix):
            return "postgresql+psycopg://" + url[len(prefix):]
    return url


def is_sqlite(url: str) -> bool:
    return url.startswith("sqlite")


def _sqlite_engine(url: str, *, immediate: bool) -> sa.Engine:
    engine = sa.create_engine(url, connect_args={"timeout": SQLITE_BUSY_TIMEOUT_MS / 1000, "check_same_thread": False},
                              pool_size=4, max_overflow=8)
    configure_sqlite_engine(engine, immediate=immediate)
    return engine


def configure_sqlite_engine(engine: sa.Engine, *, immediate: bool) -> None:
    """WAL, busy_timeout and our own BEGIN (IMMEDIATE for writers) on an SQLite engine.

    Also applied to optuna's engine on the same file, so its transactions queue on the write
    lock instead of failing on a lock upgrade.
    """

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_conn, _record):
        dbapi_conn.isolation_level = None  # we emit BEGIN ourselves (SQLAlchemy's pysqlite recipe)
        cur = dbapi_conn.cursor()
        cur.execute("PRAGMA journal_mode=WAL")
        cur.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")
        cur.execute("PRAGMA synchronous=NORMAL")
        cur.execute("PRAGMA foreign_keys=ON")
        cur.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn):
        conn.exec_driver_sql("BEGIN IMMEDIATE" if immediate else "BEGIN")

    engine.dispose()  # connections opened before the listeners existed are dropped


class Database:
    """The engines and session factories for one URL (the base of :class:`store.sql.SqlStore`)."""

    def __init__(self, url: str):
        self.url = normalize_url(url)
        self.sqlite = is_sqlite(self.url)
        if self.sqlite:
            self.engine = _sqlite_engine(self.url, immediate=True)
            self.read_engine = _sqlite_engine(self.url, immediate=False)
        else:
            # no pre-ping (one more round trip per transaction): callers retry on OperationalError
            self.engine = sa.create_engine(self.url, pool_size=5, max_overflow=10)
            self.read_engine = self.engine
        self._write = sessionmaker(self.engine, expire_on_commit=False)
        self._read = sessionmaker(self.read_engine, expire_on_commit=False)

    @contextmanager
    def write(self) -> Iterator[Session]:
        """One write transaction: committed on success, rolled back on error."""
        with self._write() as s, s.begin():
            yield s

    @contextmanager
    def read(self) -> Iterator[Session]:
        with self._read() as s, s.begin():
            yield s

    def dispose(self) -> None:
        self.engine.dispose()
        if self.read_engine is not self.engine:
            self.read_engine.dispose()
