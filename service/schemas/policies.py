"""Policy registry schemas (MLflow vocabulary): policies, versions, aliases, tags."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any

from pydantic import BaseModel, Field, StringConstraints

from registry.records import PolicyRecord, PolicyVersionRecord
from registry.references import MAX_VERSION, POLICY_REF, TAG_KEY
from service.schemas.json_schema import MAX_SAFE_INTEGER, StrictRequest, closed_mapping

TagKey = Annotated[str, StringConstraints(pattern=TAG_KEY.pattern)]
TagValue = Annotated[str, StringConstraints(max_length=1000)]


class VersionCreate(StrictRequest):
    """Register a finished job's run directory as the next version of the policy."""

    job_id: int = Field(
        ge=1, le=MAX_SAFE_INTEGER, description="A succeeded job whose run directory holds a checkpoint."
    )
    parent: str | None = Field(
        default=None,
        pattern=POLICY_REF.pattern,
        description="The version this one derives from (name, name@VERSION or name@ALIAS).",
    )
    # at most 50 tags of 1 000 characters: even fully escaped, a request stays under the 1 MB limit
    tags: dict[TagKey, TagValue] = Field(
        default_factory=dict, max_length=50, json_schema_extra=closed_mapping
    )
    description: str = Field(default="", max_length=10_000)


class AliasSet(StrictRequest):
    version: int = Field(ge=1, le=MAX_VERSION)


class TagSet(StrictRequest):
    value: str = Field(max_length=1000)


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
