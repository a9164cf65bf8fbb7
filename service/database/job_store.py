"""Queue operations on the jobs table (keyword-only functions, FastAPI-template `crud` style).

The jobs table is the queue. A claim picks the oldest queued id and moves it with `UPDATE jobs SET
status='running', owner=... WHERE id=:id AND status='queued'`: whichever supervisor's UPDATE matches
first wins, the others see 0 rows and try the next id, so a job is claimed exactly once on any
database. On PostgreSQL the pick is `SELECT ... FOR UPDATE SKIP LOCKED`, so concurrent claimers take
different rows instead of queueing behind one; on SQLite (no row locks; `FOR UPDATE` is not rendered)
the write transaction already holds the database's write lock. Writes run in `Database.write`.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any

from sqlalchemy import ColumnElement, String, cast, delete, func, literal, or_, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, aliased
from sqlalchemy.orm.attributes import set_committed_value

from registry.database import Database
from registry.models import utc_now
from service.database.models import FINISHED_STATUSES, Experiment, Job, JobArtifact, JobMetric
from service.errors import JobConflict, JobNotFound

CLAIM_RETRIES = 20


@dataclass(frozen=True)
class ClaimedJob:
    """What an executor needs to start a job."""

    id: int
    kind: str
    spec: dict[str, Any]
    resolved: dict[str, Any]
    resume: bool
    attempt: int
    run_dir: str


JOBS_AREA = "jobs"


def job_run_dir(job_id: int) -> str:
    """The run directory of a job, relative to the artifact root."""
    return f"{JOBS_AREA}/{job_id}"


def create_job(
    database: Database,
    *,
    kind: str,
    spec: dict[str, Any],
    resolved: dict[str, Any],
    progress_total: int | None,
    idempotency_key: str | None = None,
) -> tuple[Job, bool]:
    """Insert a queued job; returns (job, created). A repeated idempotency key returns the first job."""
    if idempotency_key is not None:
        with database.read() as session:
            existing = session.scalar(select(Job).where(Job.idempotency_key == idempotency_key))
            if existing is not None:
                return existing, False
    try:
        with database.write() as session:
            job = Job(
                kind=kind,
                spec=spec,
                resolved=resolved,
                status="queued",
                progress_total=progress_total,
                idempotency_key=idempotency_key,
            )
            session.add(job)
            session.flush()
            job.run_dir = job_run_dir(job.id)
        return job, True
    except IntegrityError:
        if idempotency_key is None:
            raise
        with database.read() as session:
            existing = session.scalar(select(Job).where(Job.idempotency_key == idempotency_key))
        if existing is None:
            raise
        return existing, False


def create_jobs(database: Database, items: list[dict[str, Any]], *, lock_held: bool = False) -> list[Job]:
    """Insert queued jobs (`kind`, `spec`, `resolved`, `progress_total` each) in one write transaction,
    in order; their rows. The batch path of `POST /jobs` (service/database/job_inserter.py); `lock_held`: the
    caller holds the database's write lock."""
    with database.write(lock_held=lock_held) as session:
        jobs = [
            Job(
                kind=item["kind"],
                spec=item["spec"],
                resolved=item["resolved"],
                status="queued",
                progress_total=item["progress_total"],
            )
            for item in items
        ]
        session.add_all(jobs)
        session.flush()
        # one UPDATE for the batch (not one per row: a round trip each on PostgreSQL)
        ids = [job.id for job in jobs]
        session.execute(
            update(Job)
            .where(Job.id.in_(ids))
            .values(run_dir=literal(f"{JOBS_AREA}/") + cast(Job.id, String))
            .execution_options(synchronize_session=False)
        )
        for job in jobs:
            set_committed_value(job, "run_dir", job_run_dir(job.id))
    return jobs


def get_job(database: Database, *, job_id: int) -> Job:
    with database.read() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise JobNotFound(f"no job with id {job_id}")
        return job


def get_jobs(database: Database, *, job_ids: list[int]) -> list[Job]:
    """The jobs with these ids that exist (any order)."""
    if not job_ids:
        return []
    with database.read() as session:
        return list(session.scalars(select(Job).where(Job.id.in_(job_ids))))


def existing_job_ids(database: Database, *, job_ids: set[int] | list[int]) -> set[int]:
    """Which of these job ids exist (a policy version may outlive the job it came from)."""
    if not job_ids:
        return set()
    with database.read() as session:
        return set(session.scalars(select(Job.id).where(Job.id.in_(list(job_ids)))))


def list_jobs(
    database: Database,
    *,
    status: str | None,
    kind: str | None,
    offset: int,
    limit: int,
    experiment_id: int | None = None,
) -> tuple[list[Any], int]:
    """A page of jobs (Core row objects with Job's attribute names), newest first, and the count of all
    jobs that match, read by one statement (the count is a scalar subquery evaluated once, so page and
    count share one snapshot) on an autocommit connection: the hot path of `GET /jobs`, one round trip on
    PostgreSQL. A page past the end has no row to carry the count: a second query counts."""
    conditions = []
    if status is not None:
        conditions.append(Job.status == status)
    if kind is not None:
        conditions.append(Job.kind == kind)
    if experiment_id is not None:
        conditions.append(Job.experiment_id == experiment_id)
    counter = select(func.count()).select_from(Job).where(*conditions)
    query = (
        select(*Job.__table__.columns, counter.scalar_subquery().label("matching"))
        .where(*conditions)
        .order_by(Job.id.desc())
        .offset(offset)
        .limit(limit)
    )
    with database.autocommit_read() as connection:
        rows = list(connection.execute(query))
        if rows:
            return rows, int(rows[0].matching)
        return rows, int(connection.scalar(counter) or 0)


def _experiment_has_room() -> ColumnElement[bool]:
    """A job of its own, or a cell whose experiment runs fewer cells than its `workers`."""
    sibling = aliased(Job)
    running = (
        select(func.count())
        .where(sibling.experiment_id == Job.experiment_id, sibling.status == "running")
        .scalar_subquery()
    )
    workers = select(Experiment.workers).where(Experiment.id == Job.experiment_id).scalar_subquery()
    return or_(Job.experiment_id.is_(None), running < workers)


def claim_next_job(database: Database, *, owner: str, pid: int | None = None) -> ClaimedJob | None:
    """Atomically move the oldest queued job to running under `owner`; None if the queue is empty."""
    for _ in range(CLAIM_RETRIES):
        with database.write() as session:
            candidate = session.scalar(
                select(Job.id)
                .where(Job.status == "queued", _experiment_has_room())
                .order_by(Job.id)
                .limit(1)
                .with_for_update(skip_locked=True)
            )
            if candidate is None:
                return None
            now = utc_now()
            claimed = session.execute(
                update(Job)
                .where(Job.id == candidate, Job.status == "queued")
                .values(
                    status="running",
                    owner=owner,
                    attempt=Job.attempt + 1,
                    started_at=func.coalesce(Job.started_at, now),
                    heartbeat_at=now,
                    worker_pid=pid,
                )
                .execution_options(synchronize_session=False)
            )
            if claimed.rowcount != 1:
                continue
            job = session.get(Job, candidate)
            assert job is not None
            session.refresh(job)
            return ClaimedJob(
                id=job.id,
                kind=job.kind,
                spec=dict(job.spec),
                resolved=dict(job.resolved),
                resume=job.resume,
                attempt=job.attempt,
                run_dir=job.run_dir,
            )
    return None


def set_worker_pid(database: Database, *, job_id: int, owner: str, pid: int | None) -> None:
    with database.write() as session:
        session.execute(update(Job).where(Job.id == job_id, Job.owner == owner).values(worker_pid=pid))


def request_cancel(database: Database, *, job_id: int) -> Job:
    """Cancel a queued job at once; flag a running one (its supervisor ends the process); 409 if finished."""
    with database.write() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise JobNotFound(f"no job with id {job_id}")
        if job.status in FINISHED_STATUSES:
            raise JobConflict(
                f"job {job_id} already {job.status}; only queued or running jobs can be cancelled"
            )
        if job.status == "queued":
            job.status = "cancelled"
            job.finished_at = utc_now()
            job.reason = "cancelled before it started"
        job.cancel_requested = True
        session.flush()
        return job


def delete_job(database: Database, *, job_id: int) -> Job:
    """Delete a finished job's rows (metrics and artifact records go with it); 409 if not finished."""
    with database.write() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise JobNotFound(f"no job with id {job_id}")
        if job.status not in FINISHED_STATUSES:
            raise JobConflict(
                f"job {job_id} is {job.status}; cancel it or wait until it finishes before deleting"
            )
        session.execute(delete(JobMetric).where(JobMetric.job_id == job_id))
        session.execute(delete(JobArtifact).where(JobArtifact.job_id == job_id))
        session.delete(job)
        return job


def list_metrics(database: Database, *, job_id: int, since: int, limit: int) -> list[JobMetric]:
    """Episode records with episode > since, in episode order."""
    with database.read() as session:
        if session.get(Job, job_id) is None:
            raise JobNotFound(f"no job with id {job_id}")
        return list(
            session.scalars(
                select(JobMetric)
                .where(JobMetric.job_id == job_id, JobMetric.episode > since)
                .order_by(JobMetric.episode)
                .limit(limit)
            )
        )


@dataclass(frozen=True)
class MetricSeries:
    """A job's episode records thinned for drawing: `rows` in episode order, out of `episodes` recorded,
    keeping every `stride`-th episode plus the first, the last and every greedy evaluation."""

    rows: list[JobMetric]
    episodes: int
    stride: int


EVALUATION_KEY = "eval/success_rate"
"""A record with this key holds a greedy evaluation (the trainer writes NaN, stored as null, elsewhere)."""


def metrics_after(database: Database, *, since: dict[int, int]) -> list[tuple[int, int, dict[str, Any]]]:
    """`(job_id, episode, data)` of each given job's records after its episode in `since`, by job and
    episode (one query for all the jobs: what the dashboard's success figure reads while jobs run)."""
    if not since:
        return []
    condition = or_(
        *((JobMetric.job_id == job_id) & (JobMetric.episode > episode) for job_id, episode in since.items())
    )
    query = (
        select(JobMetric.job_id, JobMetric.episode, JobMetric.data)
        .where(condition)
        .order_by(JobMetric.job_id, JobMetric.episode)
    )
    with database.read() as session:
        return [(job_id, episode, data or {}) for job_id, episode, data in session.execute(query).all()]


def metric_series(database: Database, *, job_id: int, points: int) -> MetricSeries:
    """About `points` records of a job, whatever its length: all of them up to `points`; beyond, every
    `stride`-th episode (stride = ceil(span / points)), the first and the last episode, and every record
    with a greedy evaluation (`EVALUATION_KEY`), so a drawn curve keeps its ends and each evaluation.
    The selection runs in the database (one indexed range scan; the evaluation test is a JSON lookup)."""
    with database.read() as session:
        if session.get(Job, job_id) is None:
            raise JobNotFound(f"no job with id {job_id}")
        count, first, last = session.execute(
            select(func.count(), func.min(JobMetric.episode), func.max(JobMetric.episode)).where(
                JobMetric.job_id == job_id
            )
        ).one()
        query = select(JobMetric).where(JobMetric.job_id == job_id).order_by(JobMetric.episode)
        stride = 1
        if count > points:
            stride = -(-(last - first + 1) // points)
            query = query.where(
                or_(
                    JobMetric.episode % stride == 0,
                    JobMetric.episode.in_((first, last)),
                    JobMetric.data[EVALUATION_KEY].as_float().is_not(None),
                )
            )
        return MetricSeries(rows=list(session.scalars(query)), episodes=int(count), stride=stride)


def list_artifacts(database: Database, *, job_id: int) -> list[JobArtifact]:
    with database.read() as session:
        if session.get(Job, job_id) is None:
            raise JobNotFound(f"no job with id {job_id}")
        return list(
            session.scalars(
                select(JobArtifact).where(JobArtifact.job_id == job_id).order_by(JobArtifact.name)
            )
        )


def count_by_status(database: Database) -> dict[str, int]:
    with database.read() as session:
        return dict(session.execute(select(Job.status, func.count()).group_by(Job.status)).all())


# ------------------------------------------------------------------ recovery
def running_jobs(session: Session) -> list[Job]:
    return list(session.scalars(select(Job).where(Job.status == "running").order_by(Job.id)))


def stale_running_jobs(database: Database, *, older_than: timedelta) -> list[Job]:
    cutoff: datetime = utc_now() - older_than
    with database.read() as session:
        return list(
            session.scalars(
                select(Job).where(Job.status == "running", Job.heartbeat_at < cutoff).order_by(Job.id)
            )
        )


def recover_job(
    database: Database,
    *,
    job_id: int,
    owner: str | None,
    reason: str,
    requeue: bool,
    resume: bool,
    max_attempts: int,
) -> str | None:
    """Re-queue (resuming if possible) or fail a running job whose worker is gone.

    Only acts if the job is still running under `owner` (None: any owner), so two supervisors never
    both recover it. Returns the new status, or None when the job had moved on.
    """
    with database.write() as session:
        job = session.get(Job, job_id)
        if job is None or job.status != "running" or (owner is not None and job.owner != owner):
            return None
        if job.cancel_requested:
            job.status, job.reason = "cancelled", f"cancelled ({reason})"
            job.finished_at = utc_now()
        elif requeue and job.attempt < max_attempts:
            job.status = "queued"
            job.resume = resume
            job.reason = f"re-queued after attempt {job.attempt}: {reason}" + (
                "; will resume from its last checkpoint" if resume else "; will start over"
            )
        else:
            job.status = "failed"
            tail = f" (attempt {job.attempt} of {max_attempts})" if requeue else ""
            job.reason = f"{reason}{tail}"
            job.finished_at = utc_now()
        job.owner = None
        job.worker_pid = None
        return job.status


def reset_for_fresh_start(database: Database, *, job_id: int, run_dir: Path) -> None:
    """A job re-queued without a checkpoint starts over: drop the lost attempt's metric rows."""
    with database.write() as session:
        session.execute(delete(JobMetric).where(JobMetric.job_id == job_id))
        session.execute(delete(JobArtifact).where(JobArtifact.job_id == job_id))
