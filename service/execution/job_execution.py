"""Running one job's kind function: the database-free core shared by both executors."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from service.execution.job_kinds import JobContext, job_kind


def execute_job(
    *,
    job_id: int,
    kind: str,
    spec: dict[str, Any],
    resolved: dict[str, Any],
    run_dir: Path,
    resume: bool,
    emit: Callable[[dict[str, Any]], None],
    should_stop: Callable[[], bool],
) -> dict[str, Any]:
    """Validate the stored spec again and run the kind's function in the job's run directory."""
    job = job_kind(kind)
    model = job.spec_model.model_validate(spec)
    run_dir.mkdir(parents=True, exist_ok=True)
    context = JobContext(
        job_id=job_id,
        spec=model,
        resolved=resolved,
        run_dir=run_dir,
        resume=resume,
        emit=emit,
        should_stop=should_stop,
    )
    return job.run(context)
