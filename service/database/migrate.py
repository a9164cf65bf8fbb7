"""`alembic upgrade head` for the whole service database, run programmatically at start.

Registry tables first (`registry/migrations`), then the service's (`service/database/migrations`, version
table `alembic_version_service`). The service never calls `create_all` on a live database.
"""

from __future__ import annotations

from pathlib import Path

from sqlalchemy import Engine

from registry.migrate import upgrade_registry, upgrade_to_head

MIGRATIONS = Path(__file__).resolve().parent / "migrations"


def upgrade_service(engine: Engine) -> None:
    """Bring the registry and the service tables to the newest schema."""
    upgrade_registry(engine)
    upgrade_to_head(MIGRATIONS, engine)
