"""New jobs inserted in batches by one thread per API process (group commit), so the event loop never
waits for the database's write lock.

`POST /jobs` validates and prepares a submission on the event loop, hands the row to `JobInserter.insert`
and awaits it. The inserter's thread takes every submission waiting at that moment and writes them in one
transaction (one `BEGIN IMMEDIATE` … `COMMIT` on SQLite, under the service's write lock; one commit on
PostgreSQL): under load, 20 concurrent submissions cost a few lock acquisitions instead of 20, and a
writer that the operating system preempts while it holds the lock delays one batch rather than every
request of the process. A failed batch fails each of its submissions with the same error (nothing is
half-written: the batch is one transaction). Submissions with an `Idempotency-Key` keep the one-by-one
path (`job_store.create_job`), whose replay rule needs a transaction per key.
"""

from __future__ import annotations

import asyncio
import logging
import queue
import threading
from dataclasses import dataclass
from typing import Any

from registry.database import Database
from service import job_store
from service.models import Job

log = logging.getLogger("dualsys.service")
MAX_BATCH = 64
"""Submissions written in one transaction at most."""


@dataclass
class _Pending:
    fields: dict[str, Any]
    loop: asyncio.AbstractEventLoop
    future: asyncio.Future[Job]


class JobInserter:
    """One daemon thread that writes queued submissions in batches; `insert` awaits a job's row."""

    def __init__(self, database: Database) -> None:
        self.database = database
        self._queue: queue.SimpleQueue[_Pending | None] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._start_lock = threading.Lock()
        self.batches = 0
        self.inserted = 0

    async def insert(
        self, *, kind: str, spec: dict[str, Any], resolved: dict[str, Any], progress_total: int | None
    ) -> Job:
        """The new queued job, once its batch is committed."""
        self._ensure_thread()
        loop = asyncio.get_running_loop()
        future: asyncio.Future[Job] = loop.create_future()
        fields = {"kind": kind, "spec": spec, "resolved": resolved, "progress_total": progress_total}
        self._queue.put(_Pending(fields, loop, future))
        return await future

    def stop(self) -> None:
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join(timeout=10)

    def _ensure_thread(self) -> None:
        if self._thread is not None:
            return
        with self._start_lock:
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="dualsys-job-inserter", daemon=True)
                self._thread.start()

    def _run(self) -> None:
        while True:
            first = self._queue.get()
            if first is None:
                return
            batch = [first]
            while len(batch) < MAX_BATCH:
                try:
                    item = self._queue.get_nowait()
                except queue.Empty:
                    break
                if item is None:
                    self._queue.put(None)  # stop after this batch
                    break
                batch.append(item)
            self._write(batch)

    def _write(self, batch: list[_Pending]) -> None:
        try:
            jobs = job_store.create_jobs(self.database, [pending.fields for pending in batch])
        except Exception as error:  # every submission of the batch gets the error (500, logged there)
            log.exception("inserting %d submitted job(s) failed", len(batch))
            for pending in batch:
                pending.loop.call_soon_threadsafe(_fail, pending.future, error)
            return
        self.batches += 1
        self.inserted += len(jobs)
        for pending, job in zip(batch, jobs, strict=True):
            pending.loop.call_soon_threadsafe(_resolve, pending.future, job)


def _resolve(future: asyncio.Future[Job], job: Job) -> None:
    if not future.done():
        future.set_result(job)


def _fail(future: asyncio.Future[Job], error: BaseException) -> None:
    if not future.done():
        future.set_exception(error)
