"""SQLAlchemy engine and sessions for the registry and the job service.

SQLite is the embedded default and is opened in WAL mode (readers never block the one writer),
with a busy timeout so concurrent writers wait instead of failing, and with foreign keys on.
pysqlite's own implicit transactions are switched off and BEGIN is emitted by us (SQLAlchemy's
documented recipe), so that write transactions can start with `BEGIN IMMEDIATE`: they take the
write lock up front and never hit SQLITE_BUSY half-way (read-then-write upgrades fail in WAL mode
without waiting). Other databases (PostgreSQL) use their driver's defaults.

SQLite write transactions also queue on a lock of our own: SQLite's busy handler waits by sleeping
in growing steps (up to 100 ms), so twenty threads contending for the write lock would otherwise see
p99 latencies of a second, while a blocking lock hands it over at once. Within a process that is a
`threading.Lock`; across processes (`dualsys serve --api-processes N`: N API processes and the
supervisor's process write one file) an `flock` on `<database file>-writelock`, which the kernel
hands to the next waiter as soon as it is released. Anything that writes without them (migrations,
another program) still meets SQLite's busy handler, which stays as the fallback.

Hot paths (`GET /jobs`, `POST /jobs`) use Core connections (`Database.read_connection`,
`Database.write_connection`) rather than ORM sessions: a session's unit of work costs about 0.5 ms of
CPU per request more, which is most of a request on a 2-core machine.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from pathlib import Path
from types import TracebackType

from sqlalchemy import Connection, Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.orm import Session, sessionmaker

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: SQLite's busy handler alone
    fcntl = None  # type: ignore[assignment]

SQLITE_BUSY_TIMEOUT_MS = 30_000


class WriteLock:
    """A `threading.Lock` for this process's threads, plus an `flock` on `path` for other processes."""

    def __init__(self, path: Path | None) -> None:
        self._threads = threading.Lock()
        self._path = path if fcntl is not None else None
        self._fd: int | None = None
        self._pid = 0

    def acquire(self, blocking: bool = True) -> bool:
        """Take both locks; with `blocking=False`, take neither and return False if either is held."""
        if not self._threads.acquire(blocking):
            return False
        if self._path is None:
            return True
        try:
            if self._fd is None or self._pid != os.getpid():  # a forked child opens its own
                self._fd = os.open(self._path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
                self._pid = os.getpid()
            fcntl.flock(self._fd, fcntl.LOCK_EX if blocking else fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._threads.release()
            return False
        except BaseException:
            self._threads.release()
            raise
        return True

    def release(self) -> None:
        try:
            if self._path is not None and self._fd is not None:
                fcntl.flock(self._fd, fcntl.LOCK_UN)
        finally:
            self._threads.release()

    def __enter__(self) -> None:
        self.acquire()

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        self.release()

    def close(self) -> None:
        if self._fd is not None and self._pid == os.getpid():
            os.close(self._fd)
        self._fd = None


def _sqlite_file(engine: Engine) -> Path | None:
    database = engine.url.database or ""
    if not database or database == ":memory:" or database.startswith("file:"):
        return None
    return Path(database).expanduser().resolve()


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
        options = connection.get_execution_options()
        if options.get("isolation_level") == "AUTOCOMMIT":  # `Database.autocommit_read`: no transaction
            return
        mode = options.get("sqlite_begin", "DEFERRED")
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
        self._write_lock: WriteLock | None = None
        if self.engine.dialect.name == "sqlite":
            file = _sqlite_file(self.engine)
            self._write_lock = WriteLock(file.with_name(file.name + "-writelock") if file else None)
        self._write_engine = self.engine.execution_options(sqlite_begin="IMMEDIATE")

    @contextmanager
    def read(self) -> Iterator[Session]:
        """A session for reads (its transaction is rolled back at the end)."""
        with self._reader() as session:
            yield session

    @property
    def write_lock(self) -> WriteLock | None:
        """The lock `write` takes on SQLite (None on a database server, which has row locks)."""
        return self._write_lock

    @contextmanager
    def write(self, *, lock_held: bool = False) -> Iterator[Session]:
        """A session whose transaction holds the write lock from its start; commits on success.
        `lock_held`: the caller already holds `write_lock` (and releases it)."""
        lock: AbstractContextManager[None] = nullcontext()
        if not lock_held and self._write_lock is not None:
            lock = self._write_lock
        with lock, self._writer() as session, session.begin():
            yield session

    @contextmanager
    def read_connection(self) -> Iterator[Connection]:
        """A Core connection in one read transaction (one snapshot for several queries)."""
        with self.engine.connect() as connection, connection.begin():
            yield connection

    @contextmanager
    def autocommit_read(self) -> Iterator[Connection]:
        """A Core connection without a transaction: each statement sees its own snapshot. For a read that
        is one statement, this spares `BEGIN` and `COMMIT` (two round trips on PostgreSQL)."""
        with self.engine.connect().execution_options(isolation_level="AUTOCOMMIT") as connection:
            yield connection

    @contextmanager
    def write_connection(self) -> Iterator[Connection]:
        """A Core connection whose transaction holds the write lock from its start; commits on success."""
        lock: AbstractContextManager[None] = self._write_lock or nullcontext()
        with lock, self._write_engine.connect() as connection, connection.begin():
            yield connection

    def dispose(self) -> None:
        self.engine.dispose()
        if self._write_lock is not None:
            self._write_lock.close()
