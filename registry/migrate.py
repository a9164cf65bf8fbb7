"""Programmatic `alembic upgrade head` for the registry tables (never `create_all` on a live DB).

The migration scripts ship inside the package (`registry/migrations`), with their own version
table, so the registry can be used alone (e.g. `dualsys registry register` without a service);
the job service upgrades these first, then its own (`service/database/migrations`).
"""

from __future__ import annotations

from pathlib import Path

from alembic import command
from alembic.config import Config
from sqlalchemy import Engine

MIGRATIONS = Path(__file__).resolve().parent / "migrations"


def alembic_config(script_location: Path, engine: Engine) -> Config:
    """An Alembic Config for `script_location` bound to `engine` (no alembic.ini needed)."""
    config = Config()
    config.set_main_option("script_location", str(script_location))
    url = engine.url.render_as_string(hide_password=False)
    config.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    return config


def upgrade_to_head(script_location: Path, engine: Engine) -> None:
    """Run every pending migration of `script_location` in one transaction."""
    config = alembic_config(script_location, engine)
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "head")


def upgrade_registry(engine: Engine) -> None:
    """Bring the registry tables to the newest schema."""
    upgrade_to_head(MIGRATIONS, engine)
