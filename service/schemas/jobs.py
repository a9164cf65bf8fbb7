"""Job resource schemas: JobCreate (request), JobPublic / JobsPublic (responses), metrics, artifacts.

The request body is `{"kind": "train", "spec": {...}}`; `kind` selects the spec model
(a discriminated union), so a bad spec is a 422 whose message names `spec.<field>`.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field

from service.schemas.json_schema import StrictRequest
from service.schemas.specs import AlignSpec, EvalSpec, ExportSpec, ProbeSpec, TrainSpec

JobStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]
JobKindName = Literal["train", "align", "eval", "export", "probe"]


class _Create(StrictRequest):
    """`{"kind": ..., "spec": ...}`: exactly its JSON schema."""


class TrainJobCreate(_Create):
    kind: Literal["train"]
    spec: TrainSpec = Field(default_factory=TrainSpec)


class AlignJobCreate(_Create):
    kind: Literal["align"]
    spec: AlignSpec


class EvalJobCreate(_Create):
    kind: Literal["eval"]
    spec: EvalSpec


class ExportJobCreate(_Create):
    kind: Literal["export"]
    spec: ExportSpec


class ProbeJobCreate(_Create):
    kind: Literal["probe"]
    spec: ProbeSpec = Field(default_factory=ProbeSpec)


JobCreate = Annotated[
    TrainJobCreate | AlignJobCreate | EvalJobCreate | ExportJobCreate | ProbeJobCreate,
    Field(discriminator="kind"),
]


class JobProgress(BaseModel):
    episode: int = Field(description="Last episode recorded.")
    total: int | None = Field(description="Episodes the job will run, when known.")


class JobCell(BaseModel):
    """Where a job sits in its experiment's grid (only for a cell of an experiment)."""

    key: str = Field(description="label/reward/seed-s, the cell's folder in the experiment.")
    label: str = Field(description="The method's label in the experiment file.")
    reward: str
    seed: int
    env: str | None = Field(
        default=None, description="The gymnasium id the cell trains on (`env.id` of its config), if set."
    )


class JobPublic(BaseModel):
    id: int
    kind: JobKindName
    status: JobStatus
    experiment_id: int | None = Field(description="The experiment this job is a cell of (None: its own).")
    cell: JobCell | None = Field(description="The cell of that experiment this job runs.")
    spec: dict[str, Any]
    resolved: dict[str, Any]
    reason: str | None = Field(description="Why the job failed, or why it was re-queued.")
    summary: dict[str, Any] | None
    progress: JobProgress
    attempt: int = Field(description="How many times a worker has started this job.")
    resume: bool = Field(description="The next start resumes from the job's last checkpoint.")
    cancel_requested: bool
    worker_pid: int | None
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    heartbeat_at: datetime | None


class JobsPublic(BaseModel):
    data: list[JobPublic]
    count: int = Field(description="Jobs matching the filter (all pages).")


class JobSubmitted(BaseModel):
    id: int
    status: JobStatus


class MetricPublic(BaseModel):
    episode: int
    global_step: int | None
    attempt: int
    data: dict[str, Any]
    recorded_at: datetime


class MetricsPublic(BaseModel):
    data: list[MetricPublic]
    count: int


class MetricSeriesPublic(BaseModel):
    """A job's episode records thinned for drawing (`GET /jobs/{id}/series`)."""

    data: list[MetricPublic] = Field(
        description="Every `stride`-th episode, the first and the last, and every greedy evaluation."
    )
    count: int = Field(description="Records in `data`.")
    episodes: int = Field(description="Records the job has (all of them: `GET /jobs/{id}/metrics`).")
    stride: int = Field(description="1 when `data` holds every record.")


class ArtifactPublic(BaseModel):
    name: str = Field(description="Path inside the job's run directory, e.g. checkpoints/best.pt.")
    kind: str
    size: int
    modified_at: datetime
    url: str


class ArtifactsPublic(BaseModel):
    data: list[ArtifactPublic]
    count: int
