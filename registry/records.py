"""Plain, session-free views of registry rows, returned by the Python API (and shown by the service)."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class ArtifactRecord:
    name: str  # relative name inside the version, e.g. "checkpoints/best.pt"
    kind: str  # checkpoint | onnx | config | metrics | summary | image | other
    path: Path  # absolute path in the artifact store
    size: int
    sha256: str


@dataclass(frozen=True)
class PolicyVersionRecord:
    name: str
    version: int
    created_at: datetime
    source_job_id: int | None
    source_run_dir: str
    config: dict[str, Any]
    metrics: dict[str, Any]
    parent: str | None  # "name@version" of the version this one was derived from
    description: str
    tags: dict[str, str] = field(default_factory=dict)
    aliases: list[str] = field(default_factory=list)
    artifacts: list[ArtifactRecord] = field(default_factory=list)

    @property
    def ref(self) -> str:
        return f"{self.name}@{self.version}"

    def artifact(self, name: str) -> ArtifactRecord:
        for record in self.artifacts:
            if record.name == name:
                return record
        raise KeyError(name)

    @property
    def checkpoint(self) -> Path | None:
        """The checkpoint to load: `checkpoints/best.pt`, else `latest.pt`, else any `*.pt`."""
        checkpoints = [a for a in self.artifacts if a.kind == "checkpoint"]
        for preferred in ("checkpoints/best.pt", "checkpoints/latest.pt"):
            for record in checkpoints:
                if record.name == preferred:
                    return record.path
        return checkpoints[0].path if checkpoints else None

    @property
    def onnx(self) -> Path | None:
        onnx = [a for a in self.artifacts if a.kind == "onnx"]
        return onnx[0].path if onnx else None

    @property
    def folder(self) -> Path | None:
        """The version's folder in the artifact store (where its files were copied)."""
        return (
            self.artifacts[0].path.parents[len(Path(self.artifacts[0].name).parts) - 1]
            if self.artifacts
            else None
        )


@dataclass(frozen=True)
class PolicyRecord:
    name: str
    description: str
    created_at: datetime
    latest_version: int | None
    aliases: dict[str, int]
    versions: list[PolicyVersionRecord] = field(default_factory=list)


@dataclass(frozen=True)
class PolicyOverview:
    """A policy at a glance: how many versions it has, and when and from which job its newest one came."""

    name: str
    versions: int
    latest_created_at: datetime | None
    latest_source_job_id: int | None
