"""Alembic environment of the registry tables (version table `alembic_version_registry`).

Run programmatically by `registry.migrate.upgrade_registry` with an open connection in
`config.attributes["connection"]`; `alembic -c` with a `sqlalchemy.url` works too.
"""

from __future__ import annotations

from alembic import context
from sqlalchemy import engine_from_config, pool

from registry.models import RegistryBase

VERSION_TABLE = "alembic_version_registry"
config = context.config
target_metadata = RegistryBase.metadata


def _own_tables_only(name, type_, parent_names) -> bool:  # type: ignore[no-untyped-def]
    """Autogenerate compares only this package's tables (the other package's live in the same DB)."""
    return type_ != "table" or name in target_metadata.tables


def _run(connection) -> None:  # type: ignore[no-untyped-def]
    context.configure(
        connection=connection,
        target_metadata=target_metadata,
        version_table=VERSION_TABLE,
        include_name=_own_tables_only,
        render_as_batch=connection.dialect.name == "sqlite",
    )
    with context.begin_transaction():
        context.run_migrations()


connection = config.attributes.get("connection")
if connection is not None:
    _run(connection)
else:  # pragma: no cover - command-line use
    engine = engine_from_config(config.get_section(config.config_ini_section) or {}, poolclass=pool.NullPool)
    with engine.connect() as fresh:
        _run(fresh)
