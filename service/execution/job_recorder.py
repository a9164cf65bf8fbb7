"""Writes one running job's progress to the database: metrics, heartbeats, artifact records, the end.

Runs in the service process only: both executors stream a job's records back to it (the local
worker over a pipe, a Ray task as a streaming generator) and `job_follower.follow_job` writes them
here. Job processes never hold the database's write lock, so a low-priority (niced) training
process can never make the API wait for SQLite.

Exactly-once metric history: rows are keyed by (job_id, episode). The first record an attempt
writes deletes rows at or beyond its episode (left by a lost attempt after its last checkpoint),
then every record is an upsert, so a resumed job ends with each episode exactly once.
Every write first checks that the job is still running under this owner; if not (it was recovered
elsewhere or cancelled) `LostOwnership` tells the worker to stop.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy import delete, select, update
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.orm import Session

from registry.artifact_store import ArtifactStore, artifact_kind
from registry.database import Database
from registry.models import utc_now
from service.database.models import Job, JobArtifact, JobMetric
from service.errors import LostOwnership
from service.execution.json_values import jsonable

__all__ = ["HeartbeatReply", "JobRecorder", "jsonable", "upsert"]


def upsert(session: Session, model: type, values: dict[str, Any], keys: list[str]) -> None:
    """INSERT ... ON CONFLICT (keys) DO UPDATE on SQLite/PostgreSQL; merge() elsewhere."""
    dialect = session.get_bind().dialect.name
    if dialect in ("sqlite", "postgresql"):
        insert = sqlite.insert if dialect == "sqlite" else postgresql.insert
        statement = insert(model).values(**values)
        updates = {k: statement.excluded[k] for k in values if k not in keys}
        session.execute(statement.on_conflict_do_update(index_elements=keys, set_=updates))
    else:  # pragma: no cover - other databases
        session.merge(model(**values))


@dataclass
class HeartbeatReply:
    still_owner: bool
    cancel_requested: bool


class JobRecorder:
    """The database side of one attempt of one job."""

    def __init__(self, database: Database, *, job_id: int, owner: str, attempt: int, run_dir: Path) -> None:
        self.database = database
        self.job_id = job_id
        self.owner = owner
        self.attempt = attempt
        self.run_dir = Path(run_dir)
        self._first_record = True
        self._seen: dict[str, tuple[int, int]] = {}

    def _require_owner(self, session: Session) -> Job:
        job = session.get(Job, self.job_id)
        if job is None or job.status != "running" or job.owner != self.owner:
            raise LostOwnership(f"job {self.job_id} is no longer running under {self.owner}")
        return job

    def heartbeat(self) -> HeartbeatReply:
        with self.database.write() as session:
            result = session.execute(
                update(Job)
                .where(Job.id == self.job_id, Job.owner == self.owner, Job.status == "running")
                .values(heartbeat_at=utc_now())
            )
            cancel = bool(session.scalar(select(Job.cancel_requested).where(Job.id == self.job_id)))
            return HeartbeatReply(still_owner=result.rowcount == 1, cancel_requested=cancel)

    def record_metric(self, record: dict[str, Any]) -> None:
        """Store one episode record (upsert) and refresh checkpoint records that changed."""
        data = jsonable(dict(record))
        episode = int(data["episode"])
        step = data.get("global_step")
        changed = self._changed_files(self.run_dir / "checkpoints", prefix="checkpoints/")
        with self.database.write() as session:
            job = self._require_owner(session)
            if self._first_record:
                session.execute(
                    delete(JobMetric).where(JobMetric.job_id == self.job_id, JobMetric.episode >= episode)
                )
                self._first_record = False
            upsert(
                session,
                JobMetric,
                {
                    "job_id": self.job_id,
                    "episode": episode,
                    "global_step": int(step) if isinstance(step, int | float) else None,
                    "attempt": self.attempt,
                    "data": data,
                    "recorded_at": utc_now(),
                },
                ["job_id", "episode"],
            )
            job.progress_episode = episode
            job.heartbeat_at = utc_now()
            self._record_files(session, changed)

    def _changed_files(self, folder: Path, *, prefix: str) -> list[dict[str, Any]]:
        """Artifact rows for files of `folder` that changed since last seen (stat only, no database)."""
        rows = []
        for stored in ArtifactStore.list_files(folder):
            name = prefix + stored.name
            try:
                stat = stored.path.stat()
            except OSError:  # replaced between listing and stat
                continue
            signature = (stat.st_size, stat.st_mtime_ns)
            if self._seen.get(name) == signature:
                continue
            self._seen[name] = signature
            rows.append(
                {
                    "job_id": self.job_id,
                    "name": name,
                    "kind": artifact_kind(name),
                    "size": stat.st_size,
                    "modified_at": datetime.fromtimestamp(stat.st_mtime, UTC),
                }
            )
        return rows

    @staticmethod
    def _record_files(session: Session, rows: list[dict[str, Any]]) -> None:
        for row in rows:
            upsert(session, JobArtifact, row, ["job_id", "name"])

    def finish(
        self, status: str, *, summary: dict[str, Any] | None = None, reason: str | None = None
    ) -> bool:
        """Write the job's end (succeeded/failed/cancelled) and record every run-directory file."""
        changed = self._changed_files(self.run_dir, prefix="")
        with self.database.write() as session:
            job = session.get(Job, self.job_id)
            if job is None or job.status != "running" or job.owner != self.owner:
                return False
            job.status = status
            job.summary = jsonable(summary) if summary is not None else job.summary
            if reason is not None or status != "succeeded":
                job.reason = reason  # a succeeded job keeps the note of an earlier recovery
            job.finished_at = utc_now()
            job.heartbeat_at = job.finished_at
            job.worker_pid = None
            self._record_files(session, changed)
            return True
