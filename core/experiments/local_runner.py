"""Run cells on this machine: N single-threaded worker processes, each taking one cell at a time.

The parent owns the queue and talks to each worker over its own pipe, so a worker that dies (SIGKILL,
out of memory) costs only its current cell: the cell is marked ``interrupted`` (it resumes from its latest
checkpoint on the next run), a replacement worker takes the next queued cell, and the others go on.

Workers are spawned (not forked: the parent may hold threads, and torch must start single-threaded) with
``OMP_NUM_THREADS=1`` and friends; the trainer then sets ``torch.set_num_threads(run.num_threads=1)``.
A cell whose ``run.cpu_isa`` pins the kernels' instruction set goes to a worker spawned with that pin's
variables (``core.runs.cpu_isa``); a worker only ever takes cells of its own pin, and an idle worker whose
pin no queued cell has exits to make room.

Stopping: ``should_stop()`` returning True, or Ctrl-C (SIGINT reaches the whole foreground process group),
makes every running trainer end its episode early, write ``latest.pt`` and report ``stopped``; queued cells
stay queued. A second Ctrl-C kills the workers (their cells still resume from the last checkpoint).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from core.experiments.cells import Cell, cell_cpu_isa
from core.experiments.progress import ExperimentProgress, ProgressCallback
from core.runs.cpu_isa import pinned_environment

SINGLE_THREAD_ENV: dict[str, str] = {
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MPLBACKEND": "Agg",
}
"""Environment of every worker process (read by the BLAS/OpenMP runtimes when torch is imported)."""

PROGRESS_INTERVAL_S = 0.25
"""A worker reports a running cell's step count at most this often (and after every evaluation)."""


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


# -- worker process -----------------------------------------------------------------------------------


def _worker_main(conn: Connection, stop_event: Any, log_path: str) -> None:
    """Worker loop: receive a Cell (None: exit), run it, send events back.

    The worker's stdout and stderr go to ``log_path`` (appended; PyBullet's banner and warnings would
    tear the parent's live display); what the parent needs arrives through ``conn``.
    """
    interrupted = False
    log = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.close(log)

    def on_sigint(signum: int, frame: Any) -> None:
        nonlocal interrupted
        interrupted = True

    signal.signal(signal.SIGINT, on_sigint)
    from core.experiments.cells import run_cell

    def should_stop() -> bool:
        return interrupted or stop_event.is_set()

    pid = os.getpid()
    while True:
        try:
            cell = conn.recv()
        except (EOFError, OSError):
            return
        if cell is None or should_stop():
            return
        conn.send(("started", cell.key, pid))
        reporter = _EpisodeReporter(conn, cell.key)
        try:
            summary = run_cell(cell, should_stop=should_stop, on_episode=reporter)
        except Exception as exc:
            text = str(exc).strip().splitlines()
            conn.send(("failed", cell.key, f"{type(exc).__name__}: {text[-1] if text else ''}"))
            continue
        reporter.flush()
        conn.send(("stopped" if summary.get("stopped") else "done", cell.key, _brief(summary)))


class _EpisodeReporter:
    """The trainer's on_episode hook in a worker: throttled progress messages to the parent."""

    def __init__(self, conn: Connection, key: str) -> None:
        self.conn = conn
        self.key = key
        self.last_sent = 0.0
        self.pending: list[dict[str, Any]] = []

    def __call__(self, record: dict[str, Any]) -> None:
        self.pending.append(
            {
                "episode": record.get("episode"),
                "global_step": record.get("global_step"),
                "charts/success": record.get("charts/success"),
                "eval/success_rate": record.get("eval/success_rate"),
            }
        )
        evaluated = record.get("eval/success_rate")
        now = time.monotonic()
        if now - self.last_sent >= PROGRESS_INTERVAL_S or (evaluated is not None and evaluated == evaluated):
            self.flush()

    def flush(self) -> None:
        if self.pending:
            self.conn.send(("episodes", self.key, self.pending))
            self.pending = []
            self.last_sent = time.monotonic()


def _brief(summary: dict[str, Any]) -> dict[str, Any]:
    return {key: summary.get(key) for key in ("episodes", "steps", "success_rate", "wall_s", "stopped")}


# -- parent ----------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    previous = {key: os.environ.get(key) for key in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for key, value in previous.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


@dataclass
class _Worker:
    process: Any
    conn: Connection
    cpu_isa: str
    cell: Cell | None = None
    retiring: bool = False


def run_local(
    cells: list[Cell],
    progress: ExperimentProgress,
    *,
    workers: int,
    log_path: Path,
    progress_callback: ProgressCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> None:
    """Run ``cells`` on ``workers`` processes; every outcome lands in ``progress`` (status + message).

    The workers' output is appended to ``log_path``.
    """
    context = multiprocessing.get_context("spawn")
    stop_event = context.Event()
    queue: deque[Cell] = deque(cells)
    pool: list[_Worker] = []
    stopping = False

    def notify() -> None:
        if progress_callback is not None:
            progress_callback(progress)

    def spawn(cpu_isa: str) -> _Worker:
        parent_end, child_end = context.Pipe(duplex=True)
        process = context.Process(
            target=_worker_main,
            args=(child_end, stop_event, str(log_path)),
            name="dualsys-experiment-worker",
            daemon=True,
        )
        with _environment({**SINGLE_THREAD_ENV, **pinned_environment(cpu_isa)}):
            process.start()
        child_end.close()
        worker = _Worker(process, parent_end, cpu_isa)
        pool.append(worker)
        return worker

    def take(cpu_isa: str) -> Cell | None:
        """The first queued cell of ``cpu_isa`` (removed from the queue), or None."""
        for index, cell in enumerate(queue):
            if cell_cpu_isa(cell) == cpu_isa:
                del queue[index]
                return cell
        return None

    def retire(worker: _Worker) -> None:
        """An idle worker whose pin no queued cell has: it exits (reaped as it ends)."""
        worker.retiring = True
        with contextlib.suppress(OSError, BrokenPipeError):
            worker.conn.send(None)

    def dispatch(worker: _Worker, cell: Cell) -> None:
        worker.cell = cell
        state = progress.cells[cell.key]
        state.status, state.worker, state.pid = "running", f"pid {worker.process.pid}", worker.process.pid
        worker.conn.send(cell)

    def handle(worker: _Worker, message: tuple[Any, ...]) -> None:
        kind, key = message[0], message[1]
        state = progress.cells[key]
        if kind == "started":
            state.status, state.pid, state.worker = "running", message[2], f"pid {message[2]}"
        elif kind == "episodes":
            for record in message[2]:
                state.record(record)
        else:
            if kind == "done":
                state.status, state.message = "done", ""
                state.step = int(message[2].get("steps") or state.step)
            elif kind == "stopped":
                state.status, state.message = "interrupted", "stopped; resumes from its checkpoint"
            else:
                state.status, state.message = "failed", str(message[2])
            worker.cell = None

    def reap(worker: _Worker) -> None:
        """A worker whose process ended: its cell (if any) is interrupted."""
        pool.remove(worker)
        worker.conn.close()
        worker.process.join(timeout=1)
        if worker.cell is not None:
            state = progress.cells[worker.cell.key]
            state.status = "interrupted"
            state.message = (
                f"worker pid {worker.process.pid} died (exit code {worker.process.exitcode}); "
                "resumes from its latest checkpoint"
            )

    def step(timeout: float) -> None:
        ready = wait([w.conn for w in pool] + [w.process.sentinel for w in pool], timeout=timeout)
        for worker in list(pool):
            dead = False
            try:
                while worker.conn.poll():
                    handle(worker, worker.conn.recv())
            except (EOFError, OSError):
                dead = True
            if dead or (worker.process.sentinel in ready and not worker.process.is_alive()):
                reap(worker)
        if not stopping:
            idle = [w for w in pool if w.cell is None and not w.retiring]
            for worker in idle:
                cell = take(worker.cpu_isa)
                if cell is not None:
                    dispatch(worker, cell)
                elif queue:
                    retire(worker)
            while queue and sum(not w.retiring for w in pool) < workers:
                cell = queue.popleft()
                dispatch(spawn(cell_cpu_isa(cell)), cell)
        notify()

    try:
        while (queue and not stopping) or any(w.cell is not None for w in pool):
            if not stopping and should_stop is not None and should_stop():
                stopping = True
                stop_event.set()
            step(timeout=0.5)
    except KeyboardInterrupt:
        stopping = True
        stop_event.set()
        try:
            while any(w.cell is not None for w in pool):
                step(timeout=0.5)
        except KeyboardInterrupt:
            for worker in pool:
                if worker.process.is_alive():
                    worker.process.kill()
            for worker in list(pool):
                reap(worker)
            notify()
        raise
    finally:
        for worker in pool:
            with contextlib.suppress(OSError, BrokenPipeError):
                worker.conn.send(None)
        deadline = time.monotonic() + 10
        for worker in pool:
            worker.process.join(timeout=max(0.1, deadline - time.monotonic()))
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join(timeout=1)
            worker.conn.close()
