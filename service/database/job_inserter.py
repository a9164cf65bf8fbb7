"""New jobs inserted in batches (group commit), written by the API process's event loop itself.

`POST /jobs` validates and prepares a submission on the event loop, hands the row to `JobInserter.insert`
and awaits it. The first submission of a moment schedules a flush; every submission that arrives before
the flush runs joins its batch, and the batch is written in one transaction (one `BEGIN IMMEDIATE` …
`COMMIT` under the write lock on SQLite, one commit on PostgreSQL): under load, 20 concurrent
submissions cost a few lock acquisitions instead of 20.

Where the batch is written: on SQLite, on the event loop (a millisecond of CPU work that never waits
once the lock is held); the write lock is taken without blocking when it is free, and otherwise waited
for in a pool thread, so the loop never sleeps on another process's lock. (A writer thread of its own
measured worse: every SQLite call of the thread handed the GIL back and forth with the busy loop, up to
the 5 ms switch interval each time.) On PostgreSQL the batch is written in a pool thread: its round
trips are waits that a thread overlaps.

A failed batch fails each of its submissions with the same error (nothing is half-written: the batch is
one transaction). Submissions with an `Idempotency-Key` keep the one-by-one path
(`job_store.create_job`), whose replay rule needs a transaction per key.
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass
from typing import Any

from starlette.concurrency import run_in_threadpool

from registry.database import Database
from service.database import job_store
from service.database.models import Job

log = logging.getLogger("dualsys.service")
MAX_BATCH = 64
"""Submissions written in one transaction at most."""


@dataclass
class _Pending:
    fields: dict[str, Any]
    future: asyncio.Future[Job]


class JobInserter:
    """Per event loop: queued submissions, flushed in batches; `insert` awaits a job's row."""

    def __init__(self, database: Database) -> None:
        self.database = database
        self._pending: list[_Pending] = []
        self._flushing = False
        self.batches = 0
        self.inserted = 0

    async def insert(
        self, *, kind: str, spec: dict[str, Any], resolved: dict[str, Any], progress_total: int | None
    ) -> Job:
        """The new queued job, once its batch is committed."""
        future: asyncio.Future[Job] = asyncio.get_running_loop().create_future()
        fields = {"kind": kind, "spec": spec, "resolved": resolved, "progress_total": progress_total}
        self._pending.append(_Pending(fields, future))
        if not self._flushing:
            self._flushing = True
            asyncio.get_running_loop().create_task(self._flush())
        return await future

    def stop(self) -> None:
        """Nothing to stop: a flush in progress finishes with the loop's last tasks."""

    async def _flush(self) -> None:
        try:
            while self._pending:
                await asyncio.sleep(0)  # let the requests already read in this loop turn join the batch
                batch, self._pending = self._pending[:MAX_BATCH], self._pending[MAX_BATCH:]
                await self._write(batch)
        finally:
            self._flushing = False

    async def _write(self, batch: list[_Pending]) -> None:
        items = [pending.fields for pending in batch]
        try:
            lock = self.database.write_lock
            if lock is None:  # a database server: round trips, overlapped in a pool thread
                jobs = await run_in_threadpool(job_store.create_jobs, self.database, items)
            else:
                if not lock.acquire(blocking=False):
                    await run_in_threadpool(lock.acquire)  # wait for the other writer off the loop
                try:
                    jobs = job_store.create_jobs(self.database, items, lock_held=True)
                finally:
                    lock.release()
        except Exception as error:  # every submission of the batch gets the error (a 500, logged)
            log.exception("inserting %d submitted job(s) failed", len(batch))
            for pending in batch:
                if not pending.future.done():
                    pending.future.set_exception(error)
            return
        self.batches += 1
        self.inserted += len(jobs)
        for pending, job in zip(batch, jobs, strict=True):
            if not pending.future.done():
                pending.future.set_result(job)
