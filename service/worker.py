"""One job's worker process: `python -m service.worker --job-id N --owner ...` (local executor).

The process loads its claimed job, writes heartbeats from a thread, runs the kind's function with
metrics going straight to the database (`JobRecorder`), and writes the job's end itself.
Exit codes the supervisor reads: 0 the end was written; 75 interrupted (SIGTERM without a cancel:
re-queue to resume); 4 the job was taken from it; anything else (a crash, SIGKILL) means the job's
end was never written and the supervisor recovers it. On Linux the process asks the kernel to kill
it when its supervisor dies (PR_SET_PDEATHSIG), so a killed service never leaves a worker that
keeps writing while a restarted service resumes the same job.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import os
import signal
import sys
import threading
import traceback
from pathlib import Path

from registry import PolicyRegistry, RegistryError
from registry.artifact_store import ArtifactStore
from registry.database import Database
from service.errors import JobKindUnavailable, LostOwnership
from service.job_execution import execute_job
from service.job_kinds import job_kind
from service.job_recorder import JobRecorder
from service.models import Job

EXIT_RECORDED = 0
EXIT_LOST = 4
EXIT_NOT_MINE = 3
EXIT_INTERRUPTED = 75
PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int) -> None:
    """Ask Linux to SIGKILL this process when its parent exits; exit now if it already has."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):  # exotic libc: the heartbeat check remains
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if parent_pid and os.getppid() != parent_pid:
        os._exit(EXIT_LOST)


def _parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m service.worker", description=__doc__)
    parser.add_argument("--job-id", type=int, required=True)
    parser.add_argument("--owner", required=True)
    parser.add_argument("--database-url", required=True)
    parser.add_argument("--artifacts", type=Path, required=True)
    parser.add_argument("--heartbeat-interval", type=float, default=1.0)
    parser.add_argument("--parent-pid", type=int, default=0)
    return parser.parse_args(argv)


def run_worker(args: argparse.Namespace) -> int:
    database = Database(args.database_url)
    store = ArtifactStore(args.artifacts)
    with database.read() as session:
        job = session.get(Job, args.job_id)
        if job is None or job.status != "running" or job.owner != args.owner:
            return EXIT_NOT_MINE
        kind, spec, resolved = job.kind, dict(job.spec), dict(job.resolved)
        resume, attempt, relative_run_dir = job.resume, job.attempt, job.run_dir
    run_dir = store.confine(relative_run_dir)
    recorder = JobRecorder(database, job_id=args.job_id, owner=args.owner, attempt=attempt, run_dir=run_dir)
    recorder.set_pid(os.getpid())

    stop = threading.Event()
    lost = threading.Event()
    finished = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())

    def beat() -> None:
        while not finished.wait(args.heartbeat_interval):
            try:
                reply = recorder.heartbeat()
            except Exception:  # a busy database must not kill the job; the next beat retries
                continue
            if not reply.still_owner:
                lost.set()
                stop.set()
            if reply.cancel_requested:
                stop.set()
            if args.parent_pid and os.getppid() != args.parent_pid:
                lost.set()
                stop.set()

    def emit(record: dict) -> None:
        try:
            recorder.record_metric(record)
        except LostOwnership:
            lost.set()
            stop.set()

    threading.Thread(target=beat, name=f"heartbeat-{args.job_id}", daemon=True).start()
    try:
        summary = execute_job(
            job_id=args.job_id,
            kind=kind,
            spec=spec,
            resolved=resolved,
            run_dir=run_dir,
            resume=resume,
            emit=emit,
            should_stop=stop.is_set,
        )
    except JobKindUnavailable as error:
        recorder.finish("failed", reason=str(error))
        return EXIT_RECORDED
    except LostOwnership:
        return EXIT_LOST
    except Exception as error:
        traceback.print_exc()
        if lost.is_set():
            return EXIT_LOST
        if stop.is_set() and recorder.cancel_requested():
            recorder.finish("cancelled", reason="cancelled by request")
            return EXIT_RECORDED
        if stop.is_set():
            return EXIT_INTERRUPTED
        recorder.finish("failed", reason=f"{type(error).__name__}: {error}".splitlines()[0][:2000])
        return EXIT_RECORDED
    finally:
        finished.set()

    if lost.is_set():
        return EXIT_LOST
    if stop.is_set() or summary.get("stopped"):  # the trainer also stops on SIGINT by itself
        if recorder.cancel_requested():
            recorder.finish("cancelled", summary=summary, reason="cancelled by request")
            return EXIT_RECORDED
        return EXIT_INTERRUPTED
    try:
        registry = PolicyRegistry(database, store)
        extra = job_kind(kind).after_success(
            registry, args.job_id, job_kind(kind).spec_model.model_validate(spec), resolved, run_dir, summary
        )
    except RegistryError as error:
        recorder.finish(
            "failed", summary=summary, reason=f"finished, but registering the result failed: {error}"
        )
        return EXIT_RECORDED
    recorder.finish("succeeded", summary={**summary, **extra})
    return EXIT_RECORDED


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    die_with_parent(args.parent_pid)
    return run_worker(args)


if __name__ == "__main__":
    sys.exit(main())
