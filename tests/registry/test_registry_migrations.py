"""The registry schema comes from its Alembic migrations, and they match the models."""

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect

from registry.database import Database
from registry.migrate import upgrade_registry
from registry.models import RegistryBase


def test_upgrade_creates_tables_and_is_idempotent(database_url: str) -> None:
    database = Database(database_url)
    upgrade_registry(database.engine)
    upgrade_registry(database.engine)  # a second start changes nothing
    tables = set(inspect(database.engine).get_table_names())
    assert {
        "policies",
        "policy_versions",
        "policy_aliases",
        "policy_version_tags",
        "policy_artifacts",
    } <= tables
    assert "alembic_version_registry" in tables
    with database.engine.connect() as connection:
        if database.engine.dialect.name == "sqlite":
            assert connection.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
        context = MigrationContext.configure(connection, opts={"version_table": "alembic_version_registry"})
        diff = compare_metadata(context, RegistryBase.metadata)
    assert diff == []
    database.dispose()
