"""The live progress stream of a job (`GET /jobs/{id}/events`, server-sent events).

Events: `status` (the job object, sent first and whenever its status, attempt or progress changes),
`metric` (one per episode record, `id:` = the episode, so a reconnecting client sends
`Last-Event-ID` and misses nothing), and `end` (the final job object, or `{"status": "deleted"}`
if the job is deleted while watched; the stream then closes).
A comment line keeps idle connections open. The stream polls the database (it is the queue).
"""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import AsyncIterator

from fastapi import Request
from starlette.concurrency import run_in_threadpool

from registry.database import Database
from service.api.presenters import job_public, metric_public
from service.database import job_store
from service.database.models import FINISHED_STATUSES
from service.errors import JobNotFound

POLL_S = 0.25
KEEPALIVE_S = 15.0
BATCH = 500


def sse(event: str, data: str, event_id: str | None = None) -> str:
    head = f"id: {event_id}\n" if event_id is not None else ""
    return f"{head}event: {event}\ndata: {data}\n\n"


async def job_events(request: Request, database: Database, job_id: int, since: int) -> AsyncIterator[str]:
    last_state: tuple | None = None
    last_sent = time.monotonic()
    while True:
        try:
            job = await run_in_threadpool(job_store.get_job, database, job_id=job_id)
            rows = await run_in_threadpool(
                job_store.list_metrics, database, job_id=job_id, since=since, limit=BATCH
            )
        except JobNotFound as error:  # deleted while being watched
            yield sse("end", json.dumps({"id": job_id, "status": "deleted", "detail": str(error)}))
            return
        state = (job.status, job.attempt, job.progress_episode, job.cancel_requested)
        if state != last_state:
            last_state = state
            yield sse("status", job_public(job).model_dump_json())
            last_sent = time.monotonic()
        for row in rows:
            since = row.episode
            yield sse("metric", metric_public(row).model_dump_json(), event_id=str(row.episode))
            last_sent = time.monotonic()
        if job.status in FINISHED_STATUSES and len(rows) < BATCH:
            yield sse("end", job_public(job).model_dump_json())
            return
        if await request.is_disconnected():
            return
        if time.monotonic() - last_sent > KEEPALIVE_S:
            yield ": keep-alive\n\n"
            last_sent = time.monotonic()
        if len(rows) < BATCH:
            await asyncio.sleep(POLL_S)


def parse_last_event_id(value: str | None) -> int | None:
    if value is None:
        return None
    try:
        return max(0, int(json.loads(value)))
    except (ValueError, TypeError):
        return None
