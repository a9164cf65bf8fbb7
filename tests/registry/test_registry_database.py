"""SQLite write transactions queue on an flock that other processes share (no busy-handler sleeps)."""

from __future__ import annotations

import fcntl
import os
import threading
import time
from pathlib import Path

from sqlalchemy import text

from registry.database import Database


def test_sqlite_writers_wait_for_the_file_lock_of_another_process(tmp_path: Path) -> None:
    database = Database(f"sqlite:///{tmp_path / 'w.db'}")
    with database.write_connection() as connection:
        connection.execute(text("CREATE TABLE t (x INTEGER)"))
    lock_file = tmp_path / "w.db-writelock"
    assert lock_file.exists()
    # another open file description behaves as another process would: flock excludes it
    other = os.open(lock_file, os.O_RDWR)
    fcntl.flock(other, fcntl.LOCK_EX)
    done = threading.Event()

    def write() -> None:
        with database.write() as session:
            session.execute(text("INSERT INTO t VALUES (1)"))
        done.set()

    writer = threading.Thread(target=write)
    writer.start()
    try:
        assert not done.wait(0.5)  # queued behind the other holder, not writing
        released = time.monotonic()
        fcntl.flock(other, fcntl.LOCK_UN)
        assert done.wait(5)
        assert time.monotonic() - released < 0.5  # handed over at once, not after a busy-handler sleep
    finally:
        os.close(other)
        writer.join()
    with database.read_connection() as connection:
        assert connection.scalar(text("SELECT count(*) FROM t")) == 1
    database.dispose()
