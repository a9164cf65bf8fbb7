"""Run cells as Ray tasks (one CPU each) on an existing cluster that shares the output directory.

``ray.init(address=...)`` connects to the cluster (``RAY_AUTH_MODE=token`` and its token are read from the
environment by Ray itself). Each cell is one task calling :func:`core.experiments.cells.run_cell` — the same
skip/resume/start logic as the local workers — so every node must see the output directory at the same
path (a shared filesystem) and have dualsys installed. At most ``workers`` tasks are in flight (default:
the cluster's CPUs), so an in-flight cell is a running one; the driver follows them by reading the tail of
their ``metrics.csv``. A task whose worker or node dies leaves its cell ``interrupted`` (it resumes on the
next run); ``should_stop()`` or Ctrl-C cancels the tasks gracefully (Ray raises the interrupt inside the
task, the trainer stops and writes its checkpoint), then by force after a grace period.
"""

from __future__ import annotations

import contextlib
import os
import socket
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

from core.experiments.cells import Cell, cell_cpu_isa
from core.experiments.local_runner import SINGLE_THREAD_ENV
from core.experiments.progress import ExperimentProgress, ProgressCallback, read_recent_records

PROJECT_ROOT = Path(__file__).resolve().parents[2]
STOP_GRACE_S = 60.0
"""Seconds cancelled tasks get to write their checkpoint before they are cancelled by force."""


def _cell_task(cell: Cell) -> dict[str, Any]:
    """Body of one Ray task: run the cell single-threaded; returns its summary and where it ran."""
    import ray
    import torch

    from core.experiments.cells import run_cell

    torch.set_num_threads(1)
    summary = run_cell(cell, command=f"dualsys experiment run --ray ({cell.experiment}: {cell.key})")
    node = ray.get_runtime_context().get_node_id()
    return {
        "stopped": bool(summary.get("stopped")),
        "steps": summary.get("steps"),
        "worker": f"{socket.gethostname()} node {node[:8]} pid {os.getpid()}",
        "node": node,
    }


def _pinned_options(cell: Cell) -> dict[str, Any]:
    """A cell with ``run.cpu_isa`` pinned runs in a worker process started with the pin's variables (Ray
    starts a worker for each distinct runtime environment)."""
    from core.runs.cpu_isa import pinned_environment

    pinned = pinned_environment(cell_cpu_isa(cell))
    if not pinned:
        return {}
    return {"runtime_env": {"env_vars": {**SINGLE_THREAD_ENV, "PYTHONPATH": str(PROJECT_ROOT), **pinned}}}


def run_ray(
    cells: list[Cell],
    progress: ExperimentProgress,
    *,
    address: str,
    workers: int | None = None,
    progress_callback: ProgressCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> None:
    """Run ``cells`` as Ray tasks on the cluster at ``address``; outcomes land in ``progress``."""
    try:
        import ray
    except ImportError:
        from core.experiments.spec import ExperimentError

        raise ExperimentError("--ray needs Ray: pip install 'dualsys[ray]'") from None
    owns_connection = not ray.is_initialized()
    if owns_connection:
        ray.init(
            address=address,
            log_to_driver=False,
            runtime_env={"env_vars": {**SINGLE_THREAD_ENV, "PYTHONPATH": str(PROJECT_ROOT)}},
        )
    try:
        _drive(ray, cells, progress, workers, progress_callback, should_stop)
    finally:
        if owns_connection:
            ray.shutdown()


def _drive(
    ray: Any,
    cells: list[Cell],
    progress: ExperimentProgress,
    workers: int | None,
    progress_callback: ProgressCallback | None,
    should_stop: Callable[[], bool] | None,
) -> None:
    remote = ray.remote(num_cpus=1, max_retries=0)(_cell_task)
    capacity = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
    queue: deque[Cell] = deque(cells)
    in_flight: dict[Any, Cell] = {}
    seen_episode: dict[str, int] = {}
    stopping = False
    cancelled_at: float | None = None

    def notify() -> None:
        if progress_callback is not None:
            progress_callback(progress)

    def follow(cell: Cell) -> None:
        state = progress.cells[cell.key]
        for record in read_recent_records(cell.run_dir / "metrics.csv"):
            episode = int(float(record.get("episode") or 0))
            if episode > seen_episode.get(cell.key, 0):
                seen_episode[cell.key] = episode
                state.record(record)

    def settle(reference: Any) -> None:
        cell = in_flight.pop(reference)
        state = progress.cells[cell.key]
        follow(cell)
        try:
            result = ray.get(reference)
        except ray.exceptions.RayTaskError as error:
            cause = getattr(error, "cause", None) or error
            text = str(cause).strip().splitlines()
            if isinstance(cause, KeyboardInterrupt) or stopping:
                state.status, state.message = "interrupted", "cancelled; resumes from its checkpoint"
            else:
                state.status = "failed"
                state.message = f"{type(cause).__name__}: {text[-1] if text else ''}"
            return
        except Exception as error:  # worker or node died, or the task was cancelled by force
            state.status = "interrupted"
            state.message = f"{type(error).__name__}; resumes from its latest checkpoint"
            return
        state.worker = result["worker"]
        if result["stopped"]:
            state.status, state.message = "interrupted", "stopped; resumes from its checkpoint"
        else:
            state.status, state.message = "done", ""
            state.step = int(result.get("steps") or state.step)

    def cancel(force: bool) -> None:
        for reference in list(in_flight):
            with contextlib.suppress(Exception):
                ray.cancel(reference, force=force)

    try:
        while (queue and not stopping) or in_flight:
            if not stopping and should_stop is not None and should_stop():
                stopping, cancelled_at = True, time.monotonic()
                cancel(force=False)
            while queue and not stopping and len(in_flight) < capacity:
                cell = queue.popleft()
                options = {"name": f"dualsys-cell-{cell.key}", **_pinned_options(cell)}
                in_flight[remote.options(**options).remote(cell)] = cell
                progress.cells[cell.key].status = "running"
                progress.cells[cell.key].worker = "ray"
            ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=0.5)
            for reference in ready:
                settle(reference)
            for cell in in_flight.values():
                follow(cell)
            if cancelled_at is not None and time.monotonic() - cancelled_at > STOP_GRACE_S:
                cancel(force=True)
                cancelled_at = time.monotonic()
            notify()
    except KeyboardInterrupt:
        stopping = True
        cancel(force=False)
        deadline = time.monotonic() + STOP_GRACE_S
        with contextlib.suppress(KeyboardInterrupt):
            while in_flight and time.monotonic() < deadline:
                ready, _ = ray.wait(list(in_flight), num_returns=1, timeout=0.5)
                for reference in ready:
                    settle(reference)
        cancel(force=True)
        for reference in list(in_flight):
            settle(reference)
        notify()
        raise
