"""One job's process (local executor): `python -m service.execution.worker --events-fd N ...`, job on stdin.

The process reads its job (kind, spec, resolved inputs, run directory, resume flag) as one JSON
line from stdin, runs the kind's function, and writes events (see `service.execution.job_follower`) as JSON
lines to the pipe `--events-fd`: every episode record, a heartbeat each `--heartbeat-interval`
seconds, and how it ended. After each episode record it waits for the service's acknowledgement
(a line on stdin), so the record is in the database before the job goes on to checkpoint it.
It never opens the database: the service writes everything, so a job process (run at a lower CPU
priority, `--nice`) can never hold the database's write lock.

SIGTERM (cancel, service shutdown) asks the job to stop; the trainer then writes its checkpoint and
the process reports `stopped` and exits 75. On Linux the kernel kills the process when the service
dies (PR_SET_PDEATHSIG), so a crashed service never leaves a job running that a restarted service
would run a second time; elsewhere the heartbeat thread notices the new parent and exits.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import json
import os
import signal
import sys
import threading
import traceback
from pathlib import Path
from typing import Any, TextIO

from service.execution.job_execution import execute_job
from service.execution.json_values import jsonable

EXIT_DONE = 0
EXIT_ORPHANED = 4
EXIT_INTERRUPTED = 75
PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int) -> None:
    """Ask Linux to SIGKILL this process when its parent exits; exit now if it already has."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):  # exotic libc: the heartbeat check remains
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if parent_pid and os.getppid() != parent_pid:
        os._exit(EXIT_ORPHANED)


class EventPipe:
    """Thread-safe JSON-lines writer; a broken pipe means the service is gone: exit at once."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.lock = threading.Lock()

    def send(self, event: dict[str, Any]) -> None:
        line = json.dumps(jsonable(event)) + "\n"
        with self.lock:
            try:
                self.stream.write(line)
                self.stream.flush()
            except (BrokenPipeError, OSError):
                os._exit(EXIT_ORPHANED)


def _parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m service.execution.worker", description=__doc__)
    parser.add_argument("--events-fd", type=int, required=True, help="Write end of the events pipe.")
    parser.add_argument("--heartbeat-interval", type=float, default=1.0)
    parser.add_argument("--parent-pid", type=int, default=0)
    parser.add_argument("--nice", type=int, default=0, help="Lower this process's CPU priority by this much.")
    return parser.parse_args(argv)


def wait_for_ack(acks: TextIO) -> None:
    """Block until the service has committed the last record; EOF means the service is gone."""
    if not acks.readline():
        os._exit(EXIT_ORPHANED)


def run_worker(
    job: dict[str, Any], events: EventPipe, heartbeat_s: float, parent_pid: int, acks: TextIO | None = None
) -> int:
    stop = threading.Event()
    finished = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())

    def beat() -> None:
        while not finished.wait(heartbeat_s):
            if parent_pid and os.getppid() != parent_pid:
                os._exit(EXIT_ORPHANED)
            events.send({"type": "heartbeat"})

    def emit(record: dict[str, Any]) -> None:
        events.send({"type": "metric", "record": record})
        if acks is not None:
            wait_for_ack(acks)

    threading.Thread(target=beat, name="heartbeat", daemon=True).start()
    try:
        summary = execute_job(
            job_id=int(job["id"]),
            kind=job["kind"],
            spec=job["spec"],
            resolved=job["resolved"],
            run_dir=Path(job["run_dir"]),
            resume=bool(job["resume"]),
            emit=lambda record: emit(record),
            should_stop=stop.is_set,
        )
    except Exception as error:
        traceback.print_exc()
        if stop.is_set():
            events.send({"type": "stopped", "summary": {}})
            return EXIT_INTERRUPTED
        events.send({"type": "error", "reason": f"{type(error).__name__}: {error}".splitlines()[0][:2000]})
        return EXIT_DONE
    finally:
        finished.set()
    if stop.is_set() or summary.get("stopped"):  # the trainer also stops on SIGINT by itself
        events.send({"type": "stopped", "summary": summary})
        return EXIT_INTERRUPTED
    events.send({"type": "result", "summary": summary})
    return EXIT_DONE


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    die_with_parent(args.parent_pid)
    if args.nice > 0 and hasattr(os, "nice"):
        os.nice(args.nice)  # the API process keeps priority over the training it runs
    job = json.loads(sys.stdin.readline())
    events = EventPipe(os.fdopen(args.events_fd, "w", encoding="utf-8"))
    return run_worker(job, events, args.heartbeat_interval, args.parent_pid, acks=sys.stdin)


if __name__ == "__main__":
    sys.exit(main())
