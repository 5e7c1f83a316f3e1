"""Alembic environment, configured programmatically by :func:`store.migrate.upgrade`.

The connection comes in ``config.attributes["connection"]`` (so the caller can hold a lock
around the migration); our version table is ``fc_alembic_version`` because optuna's storage in
the same database owns ``alembic_version``.
"""

from alembic import context

from store.models import Base

VERSION_TABLE = "fc_alembic_version"


def _include_object(obj, name, type_, reflected, compare_to):
    # optuna's tables share the database: compare only ours
    if type_ == "table":
        return name.startswith("fc_") and name != VERSION_TABLE
    return True


def run_migrations_online() -> None:
    connection = context.config.attributes["connection"]
    context.configure(connection=connection, target_metadata=Base.metadata, version_table=VERSION_TABLE,
                      include_object=_include_object, render_as_batch=connection.dialect.name == "sqlite")
    with context.begin_transaction():
        context.run_migrations()


if context.is_offline_mode():  # pragma: no cover - we always migrate online
    raise SystemExit("fibrecut migrations run online only (fibrecut serve / worker apply them)")
run_migrations_online()
