"""Turning job rows into their public schemas."""

from __future__ import annotations

from typing import Any

from fastapi import Response
from pydantic import BaseModel

from service.database.models import Job, JobArtifact, JobMetric
from service.schemas.jobs import ArtifactPublic, JobCell, JobProgress, JobPublic, MetricPublic


def json_response(
    model: BaseModel, status_code: int = 200, headers: dict[str, str] | None = None
) -> Response:
    """Serialise once with pydantic-core; returning a Response also skips FastAPI's second validation."""
    return Response(
        model.model_dump_json(), status_code=status_code, media_type="application/json", headers=headers
    )


def job_public(job: Job | Any) -> JobPublic:
    """From an ORM row or a Core row mapping with the same column names."""
    return JobPublic(
        id=job.id,
        kind=job.kind,  # type: ignore[arg-type]
        status=job.status,  # type: ignore[arg-type]
        experiment_id=job.experiment_id,
        cell=job_cell(job),
        spec=job.spec,
        resolved=job.resolved,
        reason=job.reason,
        summary=job.summary,
        progress=JobProgress(episode=job.progress_episode, total=job.progress_total),
        attempt=job.attempt,
        resume=job.resume,
        cancel_requested=job.cancel_requested,
        worker_pid=job.worker_pid,
        created_at=job.created_at,
        started_at=job.started_at,
        finished_at=job.finished_at,
        heartbeat_at=job.heartbeat_at,
    )


def job_cell(job: Job | Any) -> JobCell | None:
    """The cell of an experiment's job: its key (a column) and, from `resolved`, label, reward, seed and
    the config's `env.id` where the config has one."""
    if job.experiment_id is None or not job.cell:
        return None
    resolved = job.resolved or {}
    cell = resolved.get("cell") or {}
    env = ((resolved.get("config") or {}).get("env") or {}).get("id")
    label, reward, seed = _parse_key(job.cell)
    return JobCell(
        key=job.cell,
        label=str(cell.get("label", label)),
        reward=str(cell.get("reward", reward)),
        seed=int(cell.get("seed", seed)),
        env=env if isinstance(env, str) else None,
    )


def _parse_key(key: str) -> tuple[str, str, int]:
    """`label/reward/seed-s` → (label, reward, s); the fallback when `resolved.cell` is missing."""
    label, _, rest = key.partition("/")
    reward, _, seed = rest.partition("/")
    number = seed.removeprefix("seed-")
    return label, reward, int(number) if number.isdigit() else 0


def metric_public(row: JobMetric) -> MetricPublic:
    return MetricPublic(
        episode=row.episode,
        global_step=row.global_step,
        attempt=row.attempt,
        data=row.data,
        recorded_at=row.recorded_at,
    )


def artifact_public(job_id: int, row: JobArtifact) -> ArtifactPublic:
    return ArtifactPublic(
        name=row.name,
        kind=row.kind,
        size=row.size,
        modified_at=row.modified_at,
        url=f"/jobs/{job_id}/artifacts/{row.name}",
    )
