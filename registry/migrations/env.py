"""Alembic environment of the registry tables (version table `alembic_version_registry`).

Run programmatically by `registry.migrate.upgrade_registry` with an open connection in
`config.attributes["connection"]`; `alembic -c` with a `sqlalchemy.url` works too.
"""

from __future__ import annotations

from registry.migration_env import run_migrations
from registry.models import RegistryBase

run_migrations(RegistryBase.metadata, version_table="alembic_version_registry")
