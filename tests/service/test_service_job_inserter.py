"""Submissions written in batches (`service/database/job_inserter.py`, `job_store.create_jobs`): on SQLite
and on PostgreSQL, concurrent submissions from one event loop are each inserted once, in order, with their
run directories, in fewer transactions than submissions; a batch that fails fails each of its submissions
and writes nothing."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import pytest
from sqlalchemy import text

from registry.database import Database
from service.database import job_store
from service.database.job_inserter import JobInserter
from service.database.migrate import upgrade_service


@pytest.fixture()
def database(database_url: str) -> Iterator[Database]:
    db = Database(database_url)
    upgrade_service(db.engine)
    yield db
    db.dispose()


def _fields(index: int) -> dict:
    return {"kind": "probe", "spec": {"episodes": index}, "resolved": {}, "progress_total": index}


def test_concurrent_submissions_are_inserted_once_in_batches(database: Database) -> None:
    inserter = JobInserter(database)

    async def submit_all() -> list:
        return await asyncio.gather(*(inserter.insert(**_fields(i)) for i in range(1, 61)))

    try:
        jobs = asyncio.run(submit_all())
    finally:
        inserter.stop()
    assert [job.spec["episodes"] for job in jobs] == list(range(1, 61))
    assert len({job.id for job in jobs}) == 60
    assert all(job.run_dir == f"jobs/{job.id}" and job.status == "queued" for job in jobs)
    stored = job_store.get_job(database, job_id=jobs[-1].id)
    assert stored.run_dir == f"jobs/{stored.id}" and stored.progress_total == 60
    assert inserter.inserted == 60 and inserter.batches < 60  # submissions waiting together share one


def test_a_failing_batch_fails_its_submissions_and_writes_nothing(database: Database) -> None:
    with database.write() as session:  # a constraint that a second row with the same total breaks
        session.execute(text("CREATE UNIQUE INDEX one_per_total ON jobs (progress_total)"))
    with pytest.raises(Exception, match=r"(?i)unique"):
        job_store.create_jobs(database, [_fields(1), _fields(2), _fields(1)])
    assert job_store.list_jobs(database, status=None, kind=None, offset=0, limit=10)[1] == 0  # none of the 3

    job_store.create_jobs(database, [_fields(5)])
    inserter = JobInserter(database)

    async def submit() -> object:
        return await asyncio.gather(inserter.insert(**_fields(5)), return_exceptions=True)

    try:
        (result,) = asyncio.run(submit())  # type: ignore[misc]
    finally:
        inserter.stop()
    assert isinstance(result, Exception) and "unique" in str(result).lower()
    assert job_store.list_jobs(database, status=None, kind=None, offset=0, limit=10)[1] == 1
