"""SQLAlchemy 2 models of the policy registry (MLflow vocabulary: policy, version, alias, tag).

A registered policy has a unique name and integer versions from 1. A version records the job it
came from, the resolved config, a metrics summary, its artifacts, its parent version (an aligned
policy points at the one it was aligned from), its creation time and tags. An alias is a mutable
pointer from a name such as `champion` to one version. Job ids are plain integers here: the
registry knows nothing of the job service (dependency direction service → registry).
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any, ClassVar

from sqlalchemy import JSON, DateTime, ForeignKey, Integer, String, Text, TypeDecorator, UniqueConstraint
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


class UTCDateTime(TypeDecorator[datetime]):
    """A timestamp stored as naive UTC and always returned timezone-aware (SQLite drops the zone)."""

    impl = DateTime
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Any) -> datetime | None:
        if value is None:
            return None
        if value.tzinfo is not None:
            value = value.astimezone(UTC)
        return value.replace(tzinfo=None)

    def process_result_value(self, value: datetime | None, dialect: Any) -> datetime | None:
        return None if value is None else value.replace(tzinfo=UTC)


def utc_now() -> datetime:
    return datetime.now(UTC)


class RegistryBase(DeclarativeBase):
    """Declarative base of the registry tables (migrated by registry/migrations)."""

    type_annotation_map: ClassVar[dict[Any, Any]] = {dict[str, Any]: JSON, datetime: UTCDateTime}


class Policy(RegistryBase):
    __tablename__ = "policies"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    name: Mapped[str] = mapped_column(String(64), unique=True)
    description: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime] = mapped_column(default=utc_now)

    versions: Mapped[list[PolicyVersion]] = relationship(
        back_populates="policy", order_by="PolicyVersion.version", cascade="all, delete-orphan"
    )
    aliases: Mapped[list[PolicyAlias]] = relationship(
        back_populates="policy", order_by="PolicyAlias.alias", cascade="all, delete-orphan"
    )


class PolicyVersion(RegistryBase):
    __tablename__ = "policy_versions"
    __table_args__ = (UniqueConstraint("policy_id", "version", name="uq_policy_versions_policy_version"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    policy_id: Mapped[int] = mapped_column(ForeignKey("policies.id", ondelete="CASCADE"), index=True)
    version: Mapped[int] = mapped_column(Integer)
    source_job_id: Mapped[int | None] = mapped_column(Integer, default=None)
    source_run_dir: Mapped[str] = mapped_column(Text, default="")
    config: Mapped[dict[str, Any]] = mapped_column(default=dict)
    metrics: Mapped[dict[str, Any]] = mapped_column(default=dict)
    parent_id: Mapped[int | None] = mapped_column(
        ForeignKey("policy_versions.id", ondelete="SET NULL"), default=None
    )
    description: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime] = mapped_column(default=utc_now)

    policy: Mapped[Policy] = relationship(back_populates="versions")
    parent: Mapped[PolicyVersion | None] = relationship(remote_side="PolicyVersion.id")
    tags: Mapped[list[PolicyVersionTag]] = relationship(
        order_by="PolicyVersionTag.key", cascade="all, delete-orphan"
    )
    artifacts: Mapped[list[PolicyArtifact]] = relationship(
        order_by="PolicyArtifact.name", cascade="all, delete-orphan"
    )


class PolicyVersionTag(RegistryBase):
    __tablename__ = "policy_version_tags"

    version_id: Mapped[int] = mapped_column(
        ForeignKey("policy_versions.id", ondelete="CASCADE"), primary_key=True
    )
    key: Mapped[str] = mapped_column(String(64), primary_key=True)
    value: Mapped[str] = mapped_column(Text, default="")


class PolicyAlias(RegistryBase):
    __tablename__ = "policy_aliases"

    policy_id: Mapped[int] = mapped_column(ForeignKey("policies.id", ondelete="CASCADE"), primary_key=True)
    alias: Mapped[str] = mapped_column(String(32), primary_key=True)
    version_id: Mapped[int] = mapped_column(ForeignKey("policy_versions.id", ondelete="CASCADE"), index=True)
    updated_at: Mapped[datetime] = mapped_column(default=utc_now, onupdate=utc_now)

    policy: Mapped[Policy] = relationship(back_populates="aliases")
    version: Mapped[PolicyVersion] = relationship()


class PolicyArtifact(RegistryBase):
    """One file of a version, stored under the artifact root at `path` (relative to the root)."""

    __tablename__ = "policy_artifacts"

    version_id: Mapped[int] = mapped_column(
        ForeignKey("policy_versions.id", ondelete="CASCADE"), primary_key=True
    )
    name: Mapped[str] = mapped_column(String(255), primary_key=True)
    kind: Mapped[str] = mapped_column(String(16))
    path: Mapped[str] = mapped_column(Text)
    size: Mapped[int] = mapped_column(Integer)
    sha256: Mapped[str] = mapped_column(String(64))
