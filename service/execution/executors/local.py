"""The local executor: each job runs in its own `python -m service.execution.worker` process.

A crash kills one job, not the service. The worker gets its job on stdin and streams its events
back over a pipe; a thread per job (`follow_job`) writes them to the database, so only the service
process writes. Workers run in their own session (Ctrl-C in the service's terminal reaches the
service, which then stops them in order), at a lower CPU priority (`worker_nice`), and write their
output to `<run_dir>/worker.log`.
"""

from __future__ import annotations

import contextlib
import json
import os
import queue
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from registry import PolicyRegistry
from registry.artifact_store import ArtifactStore
from registry.database import Database
from service.database.job_store import ClaimedJob
from service.execution.executors.base import WorkerExit, describe_returncode, drain_exits
from service.execution.job_follower import follow_job
from service.execution.job_recorder import JobRecorder
from service.settings import ServiceSettings

PROJECT_ROOT = Path(__file__).resolve().parents[3]


@dataclass
class _Worker:
    process: subprocess.Popen[bytes]
    thread: threading.Thread
    kill_at: float | None = None


def _lines(stream) -> object:  # type: ignore[no-untyped-def]
    for line in stream:
        line = line.strip()
        if line:
            try:
                yield json.loads(line)
            except ValueError:
                continue  # a torn line from a dying process


class LocalExecutor:
    name = "local"

    def __init__(self, settings: ServiceSettings, owner: str, database: Database | None = None) -> None:
        self.settings = settings
        self.owner = owner
        self.store = ArtifactStore(settings.artifacts)
        self.database = database or Database(settings.database_url)
        self.registry = PolicyRegistry(self.database, self.store)
        self._workers: dict[int, _Worker] = {}
        self._exits: queue.Queue[WorkerExit] = queue.Queue()
        self._lock = threading.Lock()

    def free_slots(self) -> int:
        with self._lock:
            return self.settings.workers - len(self._workers)

    def _environment(self) -> dict[str, str]:
        environment = dict(os.environ)
        paths = [str(PROJECT_ROOT), *filter(None, environment.get("PYTHONPATH", "").split(os.pathsep))]
        environment["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(paths))
        environment.setdefault("PYTHONUNBUFFERED", "1")
        return environment

    def start(self, job: ClaimedJob) -> int | None:
        run_dir = self.store.confine(job.run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        read_end, write_end = os.pipe()
        with open(run_dir / "worker.log", "ab") as log:
            log.write(f"--- attempt {job.attempt} (resume={job.resume}) ---\n".encode())
            log.flush()
            command = [
                sys.executable,
                "-m",
                "service.execution.worker",
                "--events-fd",
                str(write_end),
                "--heartbeat-interval",
                str(self.settings.heartbeat_interval_s),
                "--parent-pid",
                str(os.getpid()),
                "--nice",
                str(self.settings.worker_nice),
            ]
            try:
                process = subprocess.Popen(
                    command,
                    stdin=subprocess.PIPE,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    env=self._environment(),
                    cwd=str(run_dir),
                    start_new_session=True,
                    pass_fds=(write_end,),
                )
            finally:
                os.close(write_end)
        payload = {
            "id": job.id,
            "kind": job.kind,
            "spec": job.spec,
            "resolved": job.resolved,
            "run_dir": str(run_dir),
            "resume": job.resume,
        }
        assert process.stdin is not None
        with contextlib.suppress(BrokenPipeError):
            process.stdin.write(json.dumps(payload).encode() + b"\n")
            process.stdin.flush()
        thread = threading.Thread(
            target=self._follow,
            args=(job, process, read_end, run_dir),
            name=f"follow-job-{job.id}",
            daemon=True,
        )
        with self._lock:
            self._workers[job.id] = _Worker(process=process, thread=thread)
        thread.start()
        return process.pid

    def _follow(
        self, job: ClaimedJob, process: subprocess.Popen[bytes], read_end: int, run_dir: Path
    ) -> None:
        recorder = JobRecorder(
            self.database, job_id=job.id, owner=self.owner, attempt=job.attempt, run_dir=run_dir
        )

        def acknowledge() -> None:
            assert process.stdin is not None
            with contextlib.suppress(BrokenPipeError, ValueError):
                process.stdin.write(b"ok\n")
                process.stdin.flush()

        with os.fdopen(read_end, "r", encoding="utf-8", errors="replace") as stream:
            try:
                outcome = follow_job(
                    _lines(stream),
                    recorder=recorder,
                    registry=self.registry,
                    job=job,
                    run_dir=run_dir,
                    heartbeat_interval_s=self.settings.heartbeat_interval_s,
                    acknowledge=acknowledge,
                )
                if outcome.kind == "lost":
                    process.kill()
            except Exception:  # a database failure here must not leave the job unwatched
                process.kill()
            for _ in stream:  # drain, so the process never blocks on a full pipe
                pass
        with contextlib.suppress(BrokenPipeError, OSError):
            process.stdin.close()  # type: ignore[union-attr]
        code = process.wait()
        detail = f"worker process {process.pid} ended with {describe_returncode(code)}"
        self._exits.put(WorkerExit(job_id=job.id, returncode=code, detail=detail))

    def poll(self) -> list[WorkerExit]:
        now = time.monotonic()
        with self._lock:
            for worker in self._workers.values():
                if worker.kill_at is not None and now >= worker.kill_at and worker.process.poll() is None:
                    worker.process.kill()
        return drain_exits(self._exits, self._lock, self._workers)

    def terminate(self, job_id: int) -> None:
        with self._lock:
            worker = self._workers.get(job_id)
            if worker is None or worker.kill_at is not None:
                return
            worker.kill_at = time.monotonic() + self.settings.cancel_grace_s
        with contextlib.suppress(ProcessLookupError):
            worker.process.terminate()

    def running(self) -> set[int]:
        with self._lock:
            return set(self._workers)

    def shutdown(self, grace_s: float) -> list[WorkerExit]:
        with self._lock:
            workers = list(self._workers.values())
        for worker in workers:
            with contextlib.suppress(ProcessLookupError):
                worker.process.terminate()
        deadline = time.monotonic() + grace_s
        for worker in workers:
            worker.thread.join(timeout=max(0.0, deadline - time.monotonic()))
            if worker.thread.is_alive():
                worker.process.kill()
                worker.thread.join(timeout=10)
        return self.poll()
