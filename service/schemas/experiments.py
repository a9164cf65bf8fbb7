"""Experiment resource schemas: ExperimentCreate (request), ExperimentPublic / ExperimentsPublic."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, Field

from service.schemas.json_schema import StrictRequest

EXPERIMENT_FORMAT = "dualsys-experiment"
"""The OpenAPI `format` of an experiment file's text: a client (or a fuzzer) that knows the format
generates valid files; JSON Schema cannot state the file's rules itself."""
ExperimentStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class ExperimentCreate(StrictRequest):
    content: str = Field(
        min_length=1,  # the schema says what the handler refuses: an empty file is a 422 either way
        max_length=80_000,  # 12 bytes a character at worst as JSON: under the 1 MB request limit
        description="The experiment file's text: YAML in the format of `dualsys experiment` "
        "(docs/experiments.md). A file that breaks its rules is a 422 naming the key (`content.seeds`).",
        json_schema_extra={"format": EXPERIMENT_FORMAT},
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
