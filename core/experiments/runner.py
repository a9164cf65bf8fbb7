"""Run an experiment: expand its cells, refuse changed settings, skip what is done, run the rest.

``run_experiment(spec, out, workers=..., ray_address=..., progress_callback=..., should_stop=...)`` is what
``dualsys experiment run`` and a job service call. It is idempotent: finished cells are skipped, partial
ones resume from ``checkpoints/latest.pt``, so the same call after any interruption completes the grid.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from pathlib import Path

from core.experiments.cells import (
    EXPERIMENT_FILE,
    Cell,
    cell_cpu_isa,
    cell_state,
    check_cells,
    expand_cells,
    experiment_dir,
)
from core.experiments.progress import ExperimentProgress, ProgressCallback
from core.experiments.spec import ExperimentError, ExperimentSpec
from core.runs.run_dir import atomic_write_text

WORKER_LOG = "workers.log"
"""Local workers' stdout/stderr, appended, in the experiment folder."""


@dataclass
class ExperimentPlan:
    """What a run would do: every cell, and which of them are already done."""

    spec: ExperimentSpec
    directory: Path
    cells: list[Cell]
    done: list[Cell] = field(default_factory=list)
    to_resume: list[Cell] = field(default_factory=list)
    to_start: list[Cell] = field(default_factory=list)

    @property
    def to_run(self) -> list[Cell]:
        """Partial cells first (they hold work already), then new ones, each in grid order."""
        return [*self.to_resume, *self.to_start]


@dataclass
class ExperimentResult:
    """Outcome of one :func:`run_experiment` call (cell keys per outcome)."""

    directory: Path
    cells: int
    skipped: list[str]
    done: list[str]
    failed: dict[str, str]
    interrupted: dict[str, str]
    queued: list[str]
    wall_s: float
    workers: dict[str, str] = field(default_factory=dict)
    """Where each cell run by this call ran (``pid N``, or ``host node <id> pid N`` on Ray)."""

    @property
    def complete(self) -> bool:
        """Every cell of the grid is done."""
        return not self.failed and not self.interrupted and not self.queued

    def to_dict(self) -> dict[str, object]:
        return {
            "directory": str(self.directory),
            "cells": self.cells,
            "skipped": self.skipped,
            "done": self.done,
            "failed": self.failed,
            "interrupted": self.interrupted,
            "queued": self.queued,
            "wall_s": self.wall_s,
            "complete": self.complete,
            "workers": self.workers,
        }


def plan_experiment(
    spec: ExperimentSpec, out: Path | str, *, only: Collection[str] | None = None
) -> ExperimentPlan:
    """Expand the cells and sort them by state; raises ExperimentError if a started cell's settings changed.

    ``only``: method labels; the plan then holds those methods' cells alone (the rest of the grid is left as
    it is, for a later call). Raises ExperimentError for a label the experiment does not have. Writes nothing.
    """
    cells = expand_cells(spec, out)
    if only is not None:
        labels = [method.label for method in spec.methods]
        unknown = sorted(set(only) - set(labels))
        if unknown:
            raise ExperimentError(
                f"bad value for --only: {', '.join(unknown)} (the methods are: {', '.join(labels)})"
            )
        wanted = set(only)
        cells = [cell for cell in cells if cell.label in wanted]
    check_cells(cells)
    plan = ExperimentPlan(spec=spec, directory=experiment_dir(spec, out), cells=cells)
    for cell in cells:
        {"done": plan.done, "partial": plan.to_resume, "new": plan.to_start}[cell_state(cell.run_dir)].append(
            cell
        )
    return plan


def run_experiment(
    spec: ExperimentSpec,
    out: Path | str,
    *,
    workers: int | None = None,
    ray_address: str | None = None,
    only: Collection[str] | None = None,
    progress_callback: ProgressCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> ExperimentResult:
    """Run every unfinished cell of ``spec`` under ``out/<name>/`` (of the methods labelled ``only``, if
    given: the result then speaks of those cells alone).

    ``workers``: local worker processes (default: the usable cores), or with ``ray_address`` the most Ray
    tasks in flight (default: the cluster's CPUs). ``progress_callback(progress)`` is called after every
    change; ``should_stop()`` is polled about twice a second and stops the run with every cell resumable.
    Ctrl-C does the same and re-raises KeyboardInterrupt once the workers have checkpointed.
    """
    started = time.monotonic()
    plan = plan_experiment(spec, out, only=only)
    if ray_address is None:
        check_cpu_isas(plan.to_run)
    plan.directory.mkdir(parents=True, exist_ok=True)
    atomic_write_text(plan.directory / EXPERIMENT_FILE, spec.to_yaml())
    progress = ExperimentProgress.for_cells(spec.name, [(cell.key, cell.steps) for cell in plan.cells])
    for cell in plan.done:
        state = progress.cells[cell.key]
        state.status, state.step = "skipped", cell.steps
    if progress_callback is not None:
        progress_callback(progress)
    if plan.to_run:
        if ray_address is not None:
            from core.experiments.ray_runner import run_ray

            run_ray(
                plan.to_run,
                progress,
                address=ray_address,
                workers=workers,
                progress_callback=progress_callback,
                should_stop=should_stop,
            )
        else:
            from core.experiments.local_runner import default_workers, run_local

            run_local(
                plan.to_run,
                progress,
                workers=max(1, min(workers or default_workers(), len(plan.to_run))),
                log_path=plan.directory / WORKER_LOG,
                progress_callback=progress_callback,
                should_stop=should_stop,
            )
    return _result(plan, progress, time.monotonic() - started)


def check_cpu_isas(cells: list[Cell]) -> None:
    """Refuse (one line) to run cells whose ``run.cpu_isa`` this machine's CPU lacks, before any starts.
    (On Ray each task's trainer checks its own node.)"""
    from core.runs.cpu_isa import host_problem

    for cpu_isa in sorted({cell_cpu_isa(cell) for cell in cells}):
        problem = host_problem(cpu_isa)
        if problem is not None:
            raise ExperimentError(problem)


def _result(plan: ExperimentPlan, progress: ExperimentProgress, wall_s: float) -> ExperimentResult:
    by_status: dict[str, list[str]] = {}
    for key, state in progress.cells.items():
        by_status.setdefault(state.status, []).append(key)
    return ExperimentResult(
        directory=plan.directory,
        cells=len(plan.cells),
        skipped=by_status.get("skipped", []),
        done=by_status.get("done", []),
        failed={key: progress.cells[key].message for key in by_status.get("failed", [])},
        interrupted={key: progress.cells[key].message for key in by_status.get("interrupted", [])},
        queued=by_status.get("queued", []) + by_status.get("running", []),
        wall_s=wall_s,
        workers={key: state.worker for key, state in progress.cells.items() if state.worker},
    )
