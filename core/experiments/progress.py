"""Live state of an experiment run: what each cell is doing, for a progress display or a job service.

The runners update one :class:`ExperimentProgress` and hand it to the caller's ``progress_callback`` after
every change; the callback must be quick (render, or copy :meth:`ExperimentProgress.snapshot`).
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

CellStatus = Literal["queued", "running", "done", "skipped", "failed", "interrupted"]

RECENT_EPISODES = 100
"""Training episodes behind a running cell's 'current success' (as ``dualsys train``'s progress bar)."""


@dataclass
class CellProgress:
    """One cell's live state."""

    key: str
    status: CellStatus = "queued"
    step: int = 0
    budget: int = 0
    episode: int = 0
    success: float = math.nan
    """Training success rate over the last :data:`RECENT_EPISODES` episodes."""
    eval_success: float = math.nan
    """Greedy success rate of the latest evaluation."""
    worker: str = ""
    """Who runs it: ``pid 1234`` (local) or ``host:pid`` (Ray)."""
    pid: int | None = None
    message: str = ""
    recent: deque[float] = field(default_factory=lambda: deque(maxlen=RECENT_EPISODES), repr=False)

    def record(self, episode: dict[str, Any]) -> None:
        """Fold one metrics.csv row / episode record into the state."""
        self.episode = int(float(episode.get("episode") or 0))
        self.step = int(float(episode.get("global_step") or 0))
        success = episode.get("charts/success")
        if success not in (None, ""):
            self.recent.append(float(success))
            self.success = sum(self.recent) / len(self.recent)
        evaluated = episode.get("eval/success_rate")
        if evaluated not in (None, "") and not math.isnan(float(evaluated)):
            self.eval_success = float(evaluated)


@dataclass
class ExperimentProgress:
    """Every cell's state, in grid order."""

    experiment: str
    cells: dict[str, CellProgress]
    started: float = field(default_factory=time.monotonic)

    @classmethod
    def for_cells(cls, experiment: str, keys_and_budgets: list[tuple[str, int]]) -> ExperimentProgress:
        return cls(experiment, {key: CellProgress(key, budget=budget) for key, budget in keys_and_budgets})

    def count(self, *statuses: CellStatus) -> int:
        return sum(1 for cell in self.cells.values() if cell.status in statuses)

    def running(self) -> list[CellProgress]:
        return [cell for cell in self.cells.values() if cell.status == "running"]

    def snapshot(self) -> dict[str, Any]:
        """Plain-JSON view: counts and the running cells (for a service's job progress)."""
        return {
            "experiment": self.experiment,
            "cells": len(self.cells),
            "done": self.count("done", "skipped"),
            "running": self.count("running"),
            "queued": self.count("queued"),
            "failed": self.count("failed"),
            "interrupted": self.count("interrupted"),
            "elapsed_s": time.monotonic() - self.started,
            "running_cells": [
                {
                    "key": cell.key,
                    "step": cell.step,
                    "budget": cell.budget,
                    "success": None if math.isnan(cell.success) else cell.success,
                    "eval_success": None if math.isnan(cell.eval_success) else cell.eval_success,
                    "worker": cell.worker,
                }
                for cell in self.running()
            ],
        }


ProgressCallback = Callable[[ExperimentProgress], None]


def read_recent_records(metrics_path: Path, tail_bytes: int = 16_384) -> list[dict[str, str]]:
    """The last complete rows of a metrics.csv (header + up to ``tail_bytes`` of its end), oldest first.

    Used to follow cells that run elsewhere (Ray tasks) through the shared run directories.
    """
    try:
        with metrics_path.open("rb") as file:
            header = file.readline().decode()
            file.seek(0, io.SEEK_END)
            size = file.tell()
            start = max(len(header.encode()), size - tail_bytes)
            file.seek(start)
            chunk = file.read().decode(errors="replace")
    except OSError:
        return []
    if not header.strip():
        return []
    lines = chunk.splitlines()
    if start > len(header.encode()) and lines:
        lines = lines[1:]  # the first line may be cut
    if chunk and not chunk.endswith("\n") and lines:
        lines = lines[:-1]  # being written
    reader = csv.DictReader([header, *lines])
    return list(reader)
