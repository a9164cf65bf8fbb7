"""The local executor: each job runs in its own `python -m service.worker` process.

A crash kills one job, not the service. Workers get their own session (Ctrl-C in the service's
terminal reaches the service, which then stops them in order) and write their output to
`<run_dir>/worker.log`.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from service.executors.base import WorkerExit, describe_returncode
from service.job_store import ClaimedJob
from service.settings import ServiceSettings

PROJECT_ROOT = Path(__file__).resolve().parents[2]


@dataclass
class _Worker:
    process: subprocess.Popen[bytes]
    log: object
    kill_at: float | None = None


class LocalExecutor:
    name = "local"

    def __init__(self, settings: ServiceSettings, owner: str) -> None:
        self.settings = settings
        self.owner = owner
        self.artifact_root = Path(settings.artifacts).expanduser().resolve()
        self._workers: dict[int, _Worker] = {}

    def free_slots(self) -> int:
        return self.settings.workers - len(self._workers)

    def _environment(self) -> dict[str, str]:
        environment = dict(os.environ)
        paths = [str(PROJECT_ROOT), *filter(None, environment.get("PYTHONPATH", "").split(os.pathsep))]
        environment["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(paths))
        environment.setdefault("PYTHONUNBUFFERED", "1")
        return environment

    def start(self, job: ClaimedJob) -> int | None:
        run_dir = self.artifact_root / job.run_dir
        run_dir.mkdir(parents=True, exist_ok=True)
        log = open(run_dir / "worker.log", "ab")  # noqa: SIM115 - closed when the worker is reaped
        log.write(f"--- attempt {job.attempt} (resume={job.resume}) ---\n".encode())
        log.flush()
        command = [
            sys.executable,
            "-m",
            "service.worker",
            "--job-id",
            str(job.id),
            "--owner",
            self.owner,
            "--database-url",
            self.settings.database_url,
            "--artifacts",
            str(self.artifact_root),
            "--heartbeat-interval",
            str(self.settings.heartbeat_interval_s),
            "--parent-pid",
            str(os.getpid()),
        ]
        process = subprocess.Popen(
            command,
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            env=self._environment(),
            cwd=str(run_dir),
            start_new_session=True,
        )
        self._workers[job.id] = _Worker(process=process, log=log)
        return process.pid

    def poll(self) -> list[WorkerExit]:
        exits = []
        now = time.monotonic()
        for job_id, worker in list(self._workers.items()):
            code = worker.process.poll()
            if code is None:
                if worker.kill_at is not None and now >= worker.kill_at:
                    worker.process.kill()
                continue
            exits.append(self._reap(job_id, code))
        return exits

    def _reap(self, job_id: int, code: int | None) -> WorkerExit:
        worker = self._workers.pop(job_id)
        worker.log.close()  # type: ignore[attr-defined]
        detail = f"worker process {worker.process.pid} ended with {describe_returncode(code)}"
        return WorkerExit(job_id=job_id, returncode=code, detail=detail)

    def terminate(self, job_id: int) -> None:
        worker = self._workers.get(job_id)
        if worker is None or worker.kill_at is not None:
            return
        worker.process.terminate()
        worker.kill_at = time.monotonic() + self.settings.cancel_grace_s

    def running(self) -> set[int]:
        return set(self._workers)

    def shutdown(self, grace_s: float) -> list[WorkerExit]:
        for worker in self._workers.values():
            if worker.process.poll() is None:
                worker.process.terminate()
        deadline = time.monotonic() + grace_s
        exits = []
        for job_id, worker in list(self._workers.items()):
            try:
                code = worker.process.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                worker.process.kill()
                code = worker.process.wait()
            exits.append(self._reap(job_id, code))
        return exits
