"""SQLAlchemy engine and sessions for the registry and the job service.

SQLite is the embedded default and is opened in WAL mode (readers never block the one writer),
with a busy timeout so concurrent writers wait instead of failing, and with foreign keys on.
pysqlite's own implicit transactions are switched off and BEGIN is emitted by us (SQLAlchemy's
documented recipe), so that write transactions can start with `BEGIN IMMEDIATE`: they take the
write lock up front and never hit SQLITE_BUSY half-way (read-then-write upgrades fail in WAL mode
without waiting). Other databases (PostgreSQL) use their driver's defaults.

Within one process, SQLite write transactions also queue on a `threading.Lock`: SQLite's own busy
handler waits by sleeping in growing steps (up to 100 ms), so twenty threads contending for the
write lock would otherwise see p99 latencies of a second; the Python lock hands it over at once.
Other processes (job workers) still meet at SQLite's lock, rarely, as they write once per episode.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

SQLITE_BUSY_TIMEOUT_MS = 30_000


def _configure_sqlite(engine: Engine) -> None:
    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection, _record) -> None:  # type: ignore[no-untyped-def]
        dbapi_connection.isolation_level = None  # we emit BEGIN ourselves (see module docstring)
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_TIMEOUT_MS}")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(connection) -> None:  # type: ignore[no-untyped-def]
        mode = connection.get_execution_options().get("sqlite_begin", "DEFERRED")
        connection.exec_driver_sql(f"BEGIN {mode}")


def make_engine(database_url: str) -> Engine:
    """Create an engine; SQLite URLs get WAL mode, a busy timeout and explicit BEGIN."""
    url = make_url(database_url)
    if url.get_backend_name() == "sqlite":
        database = url.database or ""
        if database and database != ":memory:" and not database.startswith("file:"):
            from pathlib import Path

            Path(database).expanduser().parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(url, connect_args={"check_same_thread": False, "timeout": 30})
        _configure_sqlite(engine)
        return engine
    return create_engine(url, pool_pre_ping=True)


class Database:
    """An engine with two session factories: plain (reads) and write (BEGIN IMMEDIATE on SQLite)."""

    def __init__(self, database_url: str) -> None:
        self.url = database_url
        self.engine = make_engine(database_url)
        self._reader = sessionmaker(self.engine, expire_on_commit=False)
        self._writer = sessionmaker(
            self.engine.execution_options(sqlite_begin="IMMEDIATE"), expire_on_commit=False
        )
        self._write_lock = threading.Lock() if self.engine.dialect.name == "sqlite" else None

    @contextmanager
    def read(self) -> Iterator[Session]:
        """A session for reads (its transaction is rolled back at the end)."""
        with self._reader() as session:
            yield session

    @contextmanager
    def write(self) -> Iterator[Session]:
        """A session whose transaction holds the write lock from its start; commits on success."""
        with self._write_lock or nullcontext(), self._writer() as session, session.begin():
            yield session

    def dispose(self) -> None:
        self.engine.dispose()
