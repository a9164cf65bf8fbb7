"""The JobKind record and the context a kind's run function receives."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel

if TYPE_CHECKING:
    from registry import PolicyRegistry


@dataclass
class JobContext:
    """Everything a run function may use: no database, only files and two callbacks."""

    job_id: int
    spec: BaseModel
    resolved: dict[str, Any]
    run_dir: Path
    resume: bool
    emit: Callable[[dict[str, Any]], None]
    """Report one episode record (must hold `episode`; `global_step` and metrics optional)."""
    should_stop: Callable[[], bool]
    """True once the job is cancelled or the service shuts down: stop soon, checkpoint if you can."""


@dataclass(frozen=True)
class Submission:
    """What `prepare` adds at submission: resolved references and the expected episode count."""

    resolved: dict[str, Any] = field(default_factory=dict)
    progress_total: int | None = None


@dataclass(frozen=True)
class JobKind:
    name: str
    spec_model: type[BaseModel]
    run: Callable[[JobContext], dict[str, Any]]
    resume_file: str | None
    """The checkpoint (relative to the run directory) an interrupted job resumes from; None: never."""
    prepare: Callable[[BaseModel, PolicyRegistry], Submission]
    after_success: Callable[
        [PolicyRegistry, int, BaseModel, dict[str, Any], Path, dict[str, Any]], dict[str, Any]
    ]
    quick_prepare: bool = False
    """`prepare` reads no files and no database and imports nothing: the API runs it on its event loop
    (the others run in the request thread pool: `train` resolves configs and imports the method registry)."""


def after_nothing(
    registry: PolicyRegistry,
    job_id: int,
    spec: BaseModel,
    resolved: dict[str, Any],
    run_dir: Path,
    summary: dict,
) -> dict[str, Any]:
    return {}
