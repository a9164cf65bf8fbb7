"""The body of an Alembic `env.py`, shared by the registry's and the service's migration folders.

Both packages keep their tables in one database, each with its own version table, so each env.py only
names its metadata and version table and calls :func:`run_migrations`.
"""

from __future__ import annotations

from alembic import context
from sqlalchemy import MetaData, engine_from_config, pool


def run_migrations(target_metadata: MetaData, version_table: str) -> None:
    """Run the migrations on `config.attributes["connection"]`, or on `sqlalchemy.url` from the CLI."""
    config = context.config

    def own_tables_only(name, type_, parent_names) -> bool:  # type: ignore[no-untyped-def]
        """Autogenerate compares only this package's tables (the other package's live in the same DB)."""
        return type_ != "table" or name in target_metadata.tables

    def run(connection) -> None:  # type: ignore[no-untyped-def]
        context.configure(
            connection=connection,
            target_metadata=target_metadata,
            version_table=version_table,
            include_name=own_tables_only,
            render_as_batch=connection.dialect.name == "sqlite",
        )
        with context.begin_transaction():
            context.run_migrations()

    connection = config.attributes.get("connection")
    if connection is not None:
        run(connection)
        return
    section = config.get_section(config.config_ini_section) or {}  # pragma: no cover - command-line use
    engine = engine_from_config(section, poolclass=pool.NullPool)  # pragma: no cover
    with engine.connect() as fresh:  # pragma: no cover
        run(fresh)
