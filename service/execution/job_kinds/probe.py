"""The `probe` kind: a diagnostic job that exercises the job machinery without training.

It emits `episodes` records (one per `interval_s`), writes an atomic JSON checkpoint after each,
resumes from that checkpoint, and can be told to fail at an episode. Its records use the trainer's
metric keys so clients (progress bars, the bench) treat it like a tiny training run.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel

from service.execution.job_kinds.base import JobContext, Submission
from service.schemas.specs import ProbeSpec

if TYPE_CHECKING:
    from registry import PolicyRegistry

CHECKPOINT = Path("checkpoints") / "latest.json"


class ProbeFailure(RuntimeError):
    """The failure a probe spec asked for (`fail_at_episode`)."""


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_text(text)
    os.replace(temporary, path)


def prepare_probe(spec: BaseModel, registry: PolicyRegistry) -> Submission:
    """A probe knows its length up front (progress bars show N/total)."""
    assert isinstance(spec, ProbeSpec)
    return Submission(progress_total=spec.episodes)


def run_probe(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, ProbeSpec)
    checkpoint = context.run_dir / CHECKPOINT
    done = 0
    if context.resume and checkpoint.is_file():
        done = int(json.loads(checkpoint.read_text())["episode"])
    for episode in range(done + 1, spec.episodes + 1):
        if context.should_stop():
            break
        if spec.interval_s:
            time.sleep(spec.interval_s)
        if spec.fail_at_episode == episode:
            raise ProbeFailure(f"probe failed at episode {episode} as its spec asked")
        context.emit(
            {
                "episode": episode,
                "global_step": episode * 10,
                "charts/episodic_return": math.sin(episode),
                "charts/success": float(episode % 2 == 0),
                "probe/pid": os.getpid(),
            }
        )
        _write_atomic(checkpoint, json.dumps({"episode": episode}))
        done = episode
    summary = {"episodes": done, "resumed": context.resume}
    _write_atomic(context.run_dir / "summary.json", json.dumps(summary))
    return summary
