"""Database fixtures for the service and queue tests: SQLite (a temporary file) and
PostgreSQL (a fresh database per test on the server at 127.0.0.1:5432, dropped afterwards).

PostgreSQL URL: $FIBRECUT_TEST_PG_URL or postgresql+psycopg://postgres@127.0.0.1:5432/test
(the admin connection; each test gets its own ``fc_t_<random>`` database). Where no server
answers the PostgreSQL cases skip with the reason, unless $CI is set: then they fail.
"""

from __future__ import annotations

import os
import uuid

import pytest

PG_ADMIN_URL = os.environ.get("FIBRECUT_TEST_PG_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test")


def _pg_conninfo(url: str) -> str:
    return url.replace("postgresql+psycopg://", "postgresql://", 1)


@pytest.fixture(scope="session")
def pg_admin():
    """A psycopg connection to the admin database, or skip (fail under CI) when none answers."""
    try:
        import psycopg

        conn = psycopg.connect(_pg_conninfo(PG_ADMIN_URL), autocommit=True, connect_timeout=3)
    except Exception as exc:  # noqa: BLE001 - any reason the server is not usable
        reason = f"PostgreSQL not reachable at {PG_ADMIN_URL}: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
        if os.environ.get("CI"):
            pytest.fail(reason + " (CI is set: the PostgreSQL tests must run)")
        pytest.skip(reason)
    yield conn
    conn.close()


def _new_pg_database(admin) -> tuple[str, str]:
    name = f"fc_t_{uuid.uuid4().hex[:12]}"
    admin.execute(f'CREATE DATABASE "{name}"')
    base, _, _ = PG_ADMIN_URL.rpartition("/")
    return name, f"{base}/{name}"


def _drop_pg_database(admin, name: str) -> None:
    from store import forget_databases
    from store.studies import forget_storages

    forget_storages()
    forget_databases()
    admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@pytest.fixture
def pg_url(pg_admin):
    name, url = _new_pg_database(pg_admin)
    yield url
    _drop_pg_database(pg_admin, name)


@pytest.fixture
def sqlite_url(tmp_path):
    from store import forget_databases
    from store.studies import forget_storages

    yield f"sqlite:///{tmp_path / 'fibrecut.db'}"
    forget_storages()
    forget_databases()


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request, tmp_path):
    """Both databases: every queue and service test runs on SQLite and on PostgreSQL."""
    if request.param == "sqlite":
        yield request.getfixturevalue("sqlite_url")
    else:
        yield request.getfixturevalue("pg_url")


@pytest.fixture
def data_dir(tmp_path):
    d = tmp_path / "data"
    d.mkdir()
    return d
