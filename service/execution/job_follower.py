"""The service side of a running job: consume its event stream and write it to the database.

Both executors produce the same events (newline-delimited JSON from a local worker's pipe, or the
items of a Ray task's streaming generator):

    {"type": "metric", "record": {...}}     one episode record
    {"type": "heartbeat"}                   the job's process is alive
    {"type": "result", "summary": {...}}    finished normally
    {"type": "error", "reason": "..."}      failed (the reason is the job's `reason`)
    {"type": "stopped", "summary": {...}}   stopped on request (cancel or shutdown): resumable

`follow_job` writes metrics and heartbeats through `JobRecorder`, and on a result runs the kind's
`after_success` (registering an aligned policy, attaching an ONNX) before marking the job
succeeded. A stream that ends without result/error/stopped means the process died: the supervisor
recovers the job from its exit.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from registry import PolicyRegistry, RegistryError
from service.database.job_store import ClaimedJob
from service.errors import LostOwnership
from service.execution.job_kinds import job_kind
from service.execution.job_recorder import JobRecorder


@dataclass(frozen=True)
class FollowOutcome:
    kind: Literal["finished", "stopped", "lost", "ended"]
    detail: str = ""


def finish_success(
    recorder: JobRecorder, registry: PolicyRegistry, job: ClaimedJob, run_dir: Path, summary: dict[str, Any]
) -> None:
    """Run the kind's after-success step, then mark the job succeeded (or failed if that step fails)."""
    kind = job_kind(job.kind)
    try:
        extra = kind.after_success(
            registry, job.id, kind.spec_model.model_validate(job.spec), job.resolved, run_dir, summary
        )
    except RegistryError as error:
        recorder.finish(
            "failed", summary=summary, reason=f"finished, but registering the result failed: {error}"
        )
        return
    recorder.finish("succeeded", summary={**summary, **extra})


def follow_job(
    events: Iterable[dict[str, Any]],
    *,
    recorder: JobRecorder,
    registry: PolicyRegistry,
    job: ClaimedJob,
    run_dir: Path,
    heartbeat_interval_s: float,
    acknowledge: Callable[[], None] | None = None,
) -> FollowOutcome:
    """Write a job's events to the database until the stream ends; say how it ended.

    `acknowledge()` is called after each metric record is committed: the local worker waits for it
    before going on (and before writing the checkpoint that covers the record), so a crash of the
    service can never leave a checkpoint ahead of the metric history.
    """
    last_write = time.monotonic()
    try:
        for event in events:
            kind = event.get("type")
            if kind == "metric":
                recorder.record_metric(event["record"])
                last_write = time.monotonic()
                if acknowledge is not None:
                    acknowledge()
            elif kind == "heartbeat":
                if time.monotonic() - last_write >= heartbeat_interval_s / 2:
                    last_write = time.monotonic()
                    if not recorder.heartbeat().still_owner:
                        return FollowOutcome("lost", f"job {job.id} is no longer ours")
            elif kind == "result":
                finish_success(recorder, registry, job, run_dir, dict(event.get("summary") or {}))
                return FollowOutcome("finished")
            elif kind == "error":
                recorder.finish("failed", reason=str(event.get("reason") or "the job failed"))
                return FollowOutcome("finished")
            elif kind == "stopped":
                return FollowOutcome("stopped")
    except LostOwnership as error:
        return FollowOutcome("lost", str(error))
    return FollowOutcome("ended")
