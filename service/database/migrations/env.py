"""Alembic environment of the job-service tables (version table `alembic_version_service`).

Run programmatically by `service.database.migrate.upgrade_service` with an open connection in
`config.attributes["connection"]`; `alembic -c` with a `sqlalchemy.url` works too.
"""

from __future__ import annotations

from registry.migration_env import run_migrations
from service.database.models import ServiceBase

run_migrations(ServiceBase.metadata, version_table="alembic_version_service")
