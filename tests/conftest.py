"""Fixtures shared by the registry and service tests: a real PostgreSQL server next to SQLite.

`postgres_server` starts one PostgreSQL cluster per test session (tests/utils/postgres_server.py) and
skips, with the reason, only where no server can be had; `postgres_url` is a fresh database on it;
`database_url` runs a test once on a SQLite file and once on PostgreSQL.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.utils.postgres_server import PostgresServer, PostgresUnavailable


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    pytest.importorskip("psycopg", reason="the PostgreSQL driver psycopg is not installed (dev extra)")
    try:
        server = PostgresServer().start()
    except PostgresUnavailable as error:
        pytest.skip(f"no PostgreSQL server: {error}")
    yield server
    server.stop()


@pytest.fixture()
def postgres_url(postgres_server: PostgresServer) -> str:
    """A fresh, empty PostgreSQL database (SQLAlchemy URL, driver psycopg 3)."""
    return postgres_server.create_database()


@pytest.fixture(params=["sqlite", "postgresql"])
def database_url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """The same test on a SQLite file and on PostgreSQL."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'dualsys.db'}"
    return request.getfixturevalue("postgres_url")
