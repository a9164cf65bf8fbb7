"""Policy registry schemas (MLflow vocabulary): policies, versions, aliases, tags."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from registry.records import PolicyRecord, PolicyVersionRecord


class VersionCreate(BaseModel):
    """Register a finished job's run directory as the next version of the policy."""

    model_config = ConfigDict(extra="forbid")

    job_id: int = Field(
        ge=1, le=2**63 - 1, description="A succeeded job whose run directory holds a checkpoint."
    )
    parent: str | None = Field(default=None, description="The version this one derives from (name@VERSION).")
    tags: dict[str, str] = Field(default_factory=dict, max_length=100)
    description: str = Field(default="", max_length=10_000)


class AliasSet(BaseModel):
    model_config = ConfigDict(extra="forbid")

    version: int = Field(ge=1, le=2**31 - 1)


class TagSet(BaseModel):
    model_config = ConfigDict(extra="forbid")

    value: str = Field(max_length=10_000)


class PolicyArtifactPublic(BaseModel):
    name: str
    kind: str
    size: int
    sha256: str
    url: str


class PolicyVersionPublic(BaseModel):
    name: str
    version: int
    ref: str
    created_at: datetime
    source_job_id: int | None
    source_run_dir: str
    config: dict[str, Any]
    metrics: dict[str, Any]
    parent: str | None
    description: str
    tags: dict[str, str]
    aliases: list[str]
    artifacts: list[PolicyArtifactPublic]

    @classmethod
    def of(cls, record: PolicyVersionRecord) -> PolicyVersionPublic:
        base = f"/policies/{record.name}/versions/{record.version}/artifacts"
        return cls(
            name=record.name,
            version=record.version,
            ref=record.ref,
            created_at=record.created_at,
            source_job_id=record.source_job_id,
            source_run_dir=record.source_run_dir,
            config=record.config,
            metrics=record.metrics,
            parent=record.parent,
            description=record.description,
            tags=record.tags,
            aliases=record.aliases,
            artifacts=[
                PolicyArtifactPublic(
                    name=a.name, kind=a.kind, size=a.size, sha256=a.sha256, url=f"{base}/{a.name}"
                )
                for a in record.artifacts
            ],
        )


class PolicyPublic(BaseModel):
    name: str
    description: str
    created_at: datetime
    latest_version: int | None
    aliases: dict[str, int]
    versions: list[PolicyVersionPublic] = Field(default_factory=list)

    @classmethod
    def of(cls, record: PolicyRecord) -> PolicyPublic:
        return cls(
            name=record.name,
            description=record.description,
            created_at=record.created_at,
            latest_version=record.latest_version,
            aliases=record.aliases,
            versions=[PolicyVersionPublic.of(v) for v in record.versions],
        )


class PoliciesPublic(BaseModel):
    data: list[PolicyPublic]
    count: int
