"""Queue operations on a real SQLite file and a real PostgreSQL server: atomic claim, cancel rules,
recovery decisions."""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from registry.database import Database
from service.database import job_store
from service.database.migrate import upgrade_service
from service.errors import JobConflict, JobNotFound


@pytest.fixture()
def database(database_url: str) -> Iterator[Database]:
    db = Database(database_url)
    upgrade_service(db.engine)
    yield db
    db.dispose()


def _queue(database: Database, count: int) -> list[int]:
    return [
        job_store.create_job(database, kind="probe", spec={}, resolved={}, progress_total=None)[0].id
        for _ in range(count)
    ]


def test_concurrent_claimers_take_each_job_exactly_once(database: Database) -> None:
    ids = _queue(database, 40)
    claims: dict[str, list[int]] = {f"owner-{i}": [] for i in range(6)}

    def claimer(owner: str) -> None:
        while (claimed := job_store.claim_next_job(database, owner=owner)) is not None:
            claims[owner].append(claimed.id)

    threads = [threading.Thread(target=claimer, args=(owner,)) for owner in claims]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    taken = [job_id for owned in claims.values() for job_id in owned]
    assert sorted(taken) == ids  # every job once, none twice
    for owner, owned in claims.items():
        for job_id in owned:
            job = job_store.get_job(database, job_id=job_id)
            assert (job.status, job.owner, job.attempt) == ("running", owner, 1)
    assert job_store.claim_next_job(database, owner="late") is None


def test_claim_order_is_oldest_first(database: Database) -> None:
    ids = _queue(database, 3)
    assert [job_store.claim_next_job(database, owner="o").id for _ in ids] == ids


def test_cancel_rules(database: Database) -> None:
    first, running, finished = _queue(database, 3)
    for _ in range(3):  # all three running under owner "o"
        job_store.claim_next_job(database, owner="o")
    assert job_store.get_job(database, job_id=first).status == "running"
    job_store.recover_job(
        database, job_id=finished, owner="o", reason="x", requeue=False, resume=False, max_attempts=1
    )
    assert job_store.get_job(database, job_id=finished).status == "failed"
    with pytest.raises(JobConflict, match="already failed"):
        job_store.request_cancel(database, job_id=finished)
    flagged = job_store.request_cancel(database, job_id=running)
    assert flagged.status == "running" and flagged.cancel_requested
    fresh = _queue(database, 1)[0]
    cancelled = job_store.request_cancel(database, job_id=fresh)
    assert cancelled.status == "cancelled" and cancelled.finished_at is not None
    with pytest.raises(JobNotFound):
        job_store.request_cancel(database, job_id=9999)
    with pytest.raises(JobConflict, match="is running"):
        job_store.delete_job(database, job_id=running)


def test_recovery_requeues_until_max_attempts_then_fails(database: Database) -> None:
    (job_id,) = _queue(database, 1)
    for attempt in (1, 2):
        claimed = job_store.claim_next_job(database, owner="o")
        assert claimed is not None and claimed.attempt == attempt
        status = job_store.recover_job(
            database,
            job_id=job_id,
            owner="o",
            reason="worker died",
            requeue=True,
            resume=True,
            max_attempts=3,
        )
        assert status == "queued"
        job = job_store.get_job(database, job_id=job_id)
        assert job.resume and job.owner is None and "worker died" in job.reason
    job_store.claim_next_job(database, owner="o")
    status = job_store.recover_job(
        database, job_id=job_id, owner="o", reason="worker died", requeue=True, resume=True, max_attempts=3
    )
    assert status == "failed"
    assert job_store.get_job(database, job_id=job_id).reason == "worker died (attempt 3 of 3)"


def test_recovery_ignores_jobs_owned_by_someone_else(database: Database) -> None:
    (job_id,) = _queue(database, 1)
    job_store.claim_next_job(database, owner="alive")
    status = job_store.recover_job(
        database, job_id=job_id, owner="someone-else", reason="x", requeue=True, resume=False, max_attempts=3
    )
    assert status is None
    assert job_store.get_job(database, job_id=job_id).owner == "alive"


def test_postgres_claim_skips_a_row_another_supervisor_holds(postgres_url: str) -> None:
    """FOR UPDATE SKIP LOCKED: while one claimer holds the oldest queued row, another takes the next
    one at once instead of waiting for it, and never the held one."""
    database = Database(postgres_url)
    upgrade_service(database.engine)
    try:
        first, second = _queue(database, 2)
        with database.engine.connect() as holder, holder.begin():
            held = holder.exec_driver_sql(
                "SELECT id FROM jobs WHERE status = 'queued' ORDER BY id LIMIT 1 FOR UPDATE"
            ).scalar()
            assert held == first
            claimed = job_store.claim_next_job(database, owner="b")
            assert claimed is not None and claimed.id == second
            assert job_store.claim_next_job(database, owner="b") is None  # the held row stays untouched
        assert job_store.claim_next_job(database, owner="a").id == first
    finally:
        database.dispose()
