"""Experiment resource schemas: ExperimentCreate (request), ExperimentPublic / ExperimentsPublic."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

ExperimentStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class ExperimentCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")

    content: str = Field(
        max_length=200_000,
        description="The experiment file's text (YAML, the format of `dualsys experiment`).",
    )
    workers: int = Field(default=1, ge=1, le=64, description="Cells of this experiment run at once, at most.")


class CellCounts(BaseModel):
    total: int
    done: int = Field(description="Cells whose job succeeded.")
    running: int
    queued: int
    failed: int
    cancelled: int


class CellPublic(BaseModel):
    job_id: int
    cell: str = Field(description="label/reward/seed-s")
    status: str
    attempt: int
    episode: int
    reason: str | None


class ExperimentPublic(BaseModel):
    id: int
    name: str
    status: ExperimentStatus
    workers: int
    cancel_requested: bool
    created_at: datetime
    spec: dict[str, Any] = Field(description="The experiment file, validated and normalised.")
    cells: CellCounts
    jobs: list[CellPublic]
    report: dict[str, Any] | None = Field(
        description="`core.experiments.build_report` on the cells' run directories, once a cell is done "
        "(its `done` says how many cells it covers)."
    )
    report_pending: bool = Field(description="A report of more finished cells is being computed (ask again).")


class ExperimentSummary(BaseModel):
    id: int
    name: str
    workers: int
    cancel_requested: bool
    created_at: datetime


class ExperimentsPublic(BaseModel):
    data: list[ExperimentSummary]
    count: int
