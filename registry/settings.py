"""Where the policy registry lives: a database URL and an artifact root.

Both come from pydantic-settings with the `DUALSYS_` env prefix, so `DUALSYS_DATABASE_URL` and
`DUALSYS_ARTIFACTS` point the registry (and the job service, whose settings extend these) at
another database (e.g. PostgreSQL) or another folder. SQLite in WAL mode is the embedded default.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

DEFAULT_DATABASE_FILE = Path("dualsys.db")
DEFAULT_ARTIFACT_ROOT = Path("dualsys-artifacts")


def sqlite_url(path: Path) -> str:
    """The SQLAlchemy URL of a SQLite file (absolute, so workers in other folders find it)."""
    return f"sqlite:///{Path(path).expanduser().resolve()}"


class RegistrySettings(BaseSettings):
    """Location of the registry database and artifact store (env prefix `DUALSYS_`)."""

    model_config = SettingsConfigDict(env_prefix="DUALSYS_", extra="ignore")

    database_url: str = Field(default_factory=lambda: sqlite_url(DEFAULT_DATABASE_FILE))
    """SQLAlchemy URL; the default is a SQLite file `./dualsys.db` (WAL mode)."""
    artifacts: Path = DEFAULT_ARTIFACT_ROOT
    """Artifact root: registered policy files and job run directories live below it."""
