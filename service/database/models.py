"""SQLAlchemy 2 models of the job service: the jobs table is the queue.

- `jobs`: one row per submitted job; `status` moves queued → running → succeeded|failed|cancelled
  (and running → queued again when a lost job is recovered). `owner` is the supervisor that
  claimed it; workers write `heartbeat_at`; a claim is an UPDATE ... WHERE status='queued'.
- `job_metrics`: one row per training episode, primary key (job_id, episode), so a resumed run
  that repeats episodes overwrites instead of doubling them.
- `job_artifacts`: one record per file of the job's run directory (checkpoints recorded as they are
  written), primary key (job_id, name), upserted on change.
- `experiments`: one row per submitted experiment file (`core.experiments`); its cells are ordinary
  `train` jobs with `experiment_id` set, whose run directories form the experiment's folder
  `experiments/<id>/<name>/<label>/<reward>/seed-<s>`, so the library's report reads them as they are.
  At most `workers` of an experiment's cells run at once (the claim checks it).
"""

from __future__ import annotations

from datetime import datetime
from typing import Any, ClassVar

from sqlalchemy import JSON, Boolean, ForeignKey, Index, Integer, String, Text
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from registry.models import UTCDateTime, utc_now

JOB_STATUSES = ("queued", "running", "succeeded", "failed", "cancelled")
FINISHED_STATUSES = frozenset({"succeeded", "failed", "cancelled"})


class ServiceBase(DeclarativeBase):
    """Declarative base of the service tables (migrated by service/database/migrations)."""

    type_annotation_map: ClassVar[dict[Any, Any]] = {dict[str, Any]: JSON, datetime: UTCDateTime}


class Job(ServiceBase):
    __tablename__ = "jobs"
    __table_args__ = (
        Index("ix_jobs_status_id", "status", "id"),
        Index("ix_jobs_kind_id", "kind", "id"),
        {"sqlite_autoincrement": True},  # ids are never reused after DELETE /jobs/{id}
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    kind: Mapped[str] = mapped_column(String(16))
    spec: Mapped[dict[str, Any]] = mapped_column(default=dict)
    """The spec as validated at submission (pydantic defaults filled in)."""
    resolved: Mapped[dict[str, Any]] = mapped_column(default=dict)
    """What the spec resolved to at submission: `name@alias` → `name@version` + checkpoint, config."""
    status: Mapped[str] = mapped_column(String(16), default="queued")
    reason: Mapped[str | None] = mapped_column(Text, default=None)
    """Why the job failed, or why it was re-queued (worker lost, service restart)."""
    summary: Mapped[dict[str, Any] | None] = mapped_column(JSON, default=None)
    created_at: Mapped[datetime] = mapped_column(default=utc_now)
    started_at: Mapped[datetime | None] = mapped_column(default=None)
    finished_at: Mapped[datetime | None] = mapped_column(default=None)
    heartbeat_at: Mapped[datetime | None] = mapped_column(default=None)
    owner: Mapped[str | None] = mapped_column(String(128), default=None)
    worker_pid: Mapped[int | None] = mapped_column(Integer, default=None)
    attempt: Mapped[int] = mapped_column(Integer, default=0)
    resume: Mapped[bool] = mapped_column(Boolean, default=False)
    cancel_requested: Mapped[bool] = mapped_column(Boolean, default=False)
    progress_episode: Mapped[int] = mapped_column(Integer, default=0)
    progress_total: Mapped[int | None] = mapped_column(Integer, default=None)
    run_dir: Mapped[str] = mapped_column(Text, default="")
    """The job's run directory relative to the artifact root (`jobs/<id>`)."""
    idempotency_key: Mapped[str | None] = mapped_column(String(128), default=None, unique=True)
    experiment_id: Mapped[int | None] = mapped_column(Integer, default=None, index=True)
    """The experiment (`experiments.id`) this job is a cell of (None: a job of its own). No foreign key:
    adding one to SQLite's jobs table would copy the table, and experiments are never deleted."""
    cell: Mapped[str | None] = mapped_column(String(255), default=None)
    """The cell's key within its experiment (`label/reward/seed-s`)."""


class Experiment(ServiceBase):
    __tablename__ = "experiments"
    __table_args__ = ({"sqlite_autoincrement": True},)

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    name: Mapped[str] = mapped_column(String(128))
    spec: Mapped[dict[str, Any]] = mapped_column(default=dict)
    """The validated experiment file, normalised (`ExperimentSpec.to_dict`)."""
    workers: Mapped[int] = mapped_column(Integer, default=1)
    """How many of its cells may run at once."""
    directory: Mapped[str] = mapped_column(Text, default="")
    """The experiment folder relative to the artifact root (`experiments/<id>/<name>`)."""
    cancel_requested: Mapped[bool] = mapped_column(Boolean, default=False)
    created_at: Mapped[datetime] = mapped_column(default=utc_now)


class JobMetric(ServiceBase):
    __tablename__ = "job_metrics"

    job_id: Mapped[int] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    episode: Mapped[int] = mapped_column(Integer, primary_key=True)
    global_step: Mapped[int | None] = mapped_column(Integer, default=None)
    attempt: Mapped[int] = mapped_column(Integer, default=1)
    """The job attempt that wrote this row (a resumed attempt may overwrite a lost one's rows)."""
    data: Mapped[dict[str, Any]] = mapped_column(default=dict)
    recorded_at: Mapped[datetime] = mapped_column(default=utc_now)


class JobArtifact(ServiceBase):
    __tablename__ = "job_artifacts"

    job_id: Mapped[int] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    name: Mapped[str] = mapped_column(String(255), primary_key=True)
    kind: Mapped[str] = mapped_column(String(16))
    size: Mapped[int] = mapped_column(Integer)
    modified_at: Mapped[datetime] = mapped_column(default=utc_now)
