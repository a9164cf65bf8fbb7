"""The service schema comes from Alembic migrations (never create_all), and they match the models."""

from __future__ import annotations

from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect

from registry.database import Database
from service.database.migrate import upgrade_service
from service.database.models import ServiceBase


def test_upgrade_head_builds_both_schemas_and_matches_the_models(database_url: str) -> None:
    database = Database(database_url)
    upgrade_service(database.engine)
    upgrade_service(database.engine)  # a restart finds nothing to do
    tables = set(inspect(database.engine).get_table_names())
    assert {"jobs", "job_metrics", "job_artifacts", "policies", "policy_versions"} <= tables
    assert {"alembic_version_service", "alembic_version_registry"} <= tables
    with database.engine.connect() as connection:
        if database.engine.dialect.name == "sqlite":
            assert connection.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
        options = {
            "version_table": "alembic_version_service",
            "include_name": lambda name, kind, _: kind != "table" or name in ServiceBase.metadata.tables,
        }
        diff = compare_metadata(MigrationContext.configure(connection, opts=options), ServiceBase.metadata)
    assert diff == []
    database.dispose()
