"""Turning job rows into their public schemas."""

from __future__ import annotations

from typing import Any

from fastapi import Response
from pydantic import BaseModel

from service.models import Job, JobArtifact, JobMetric
from service.schemas.jobs import ArtifactPublic, JobProgress, JobPublic, MetricPublic


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
