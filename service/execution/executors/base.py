"""The interface between the supervisor and an executor."""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass
from typing import Any, Protocol

from service.database.job_store import ClaimedJob

EXIT_INTERRUPTED = 75  # the worker stopped without a cancel request: re-queue to resume


@dataclass(frozen=True)
class WorkerExit:
    """A job's worker has ended (whether its end was recorded is read from the jobs table)."""

    job_id: int
    returncode: int | None
    detail: str


class Executor(Protocol):
    name: str

    def free_slots(self) -> int:
        """How many more jobs can start now."""
        ...

    def start(self, job: ClaimedJob) -> int | None:
        """Start a claimed job; returns the worker's pid when there is a local one."""
        ...

    def poll(self) -> list[WorkerExit]:
        """Workers that ended since the last poll."""
        ...

    def terminate(self, job_id: int) -> None:
        """Ask a job's worker to stop (then kill it after the grace period)."""
        ...

    def running(self) -> set[int]:
        """Ids of the jobs whose workers are alive."""
        ...

    def shutdown(self, grace_s: float) -> list[WorkerExit]:
        """Stop every worker (SIGTERM, then SIGKILL after grace_s) and report their exits."""
        ...


def describe_returncode(returncode: int | None) -> str:
    if returncode is None:
        return "an unknown status"
    if returncode < 0:
        import signal

        try:
            return f"signal {-returncode} ({signal.Signals(-returncode).name})"
        except ValueError:
            return f"signal {-returncode}"
    return f"exit code {returncode}"


def drain_exits(
    exits: queue.Queue[WorkerExit], lock: threading.Lock, live: dict[int, Any]
) -> list[WorkerExit]:
    """Take every reported exit off `exits`, forgetting each job in `live` (an executor's running table)."""
    drained = []
    while True:
        try:
            exit_ = exits.get_nowait()
        except queue.Empty:
            return drained
        with lock:
            live.pop(exit_.job_id, None)
        drained.append(exit_)
