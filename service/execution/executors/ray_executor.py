"""The Ray executor: each job runs as a Ray task (`ray_task.run_job_stream`) on a Ray cluster.

`--ray-address` names the cluster (None: a local Ray is started, `ray_num_cpus` CPUs). A driver
thread per job follows the task's record stream and writes metrics, heartbeats and the job's end
through `job_follower.follow_job`, exactly as for the local executor. Cancel and shutdown cancel the task
(`ray.cancel(force=True)` ends its worker process); the job then resumes from its last periodic
checkpoint when re-queued. Ray is an optional extra: `pip install 'dualsys[ray]'`.
"""

from __future__ import annotations

import contextlib
import queue
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from registry import PolicyRegistry
from registry.artifact_store import ArtifactStore
from registry.database import Database
from service.database.job_store import ClaimedJob
from service.execution.executors.base import WorkerExit, drain_exits
from service.execution.job_follower import follow_job
from service.execution.job_recorder import JobRecorder
from service.settings import ServiceSettings

PROJECT_ROOT = Path(__file__).resolve().parents[3]
EXIT_CANCELLED = -9


@dataclass
class _RayJob:
    job: ClaimedJob
    stream: Any
    thread: threading.Thread | None = None
    cancelled: threading.Event = field(default_factory=threading.Event)


def _cause_message(error: BaseException) -> str:
    cause = getattr(error, "cause", None)
    chosen = cause if isinstance(cause, BaseException) else error
    text = str(chosen).strip().splitlines()
    return f"{type(chosen).__name__}: {text[-1] if text else ''}"[:2000]


class RayExecutor:
    name = "ray"

    def __init__(self, settings: ServiceSettings, owner: str, database: Database | None = None) -> None:
        import ray

        self.ray = ray
        self.settings = settings
        self.owner = owner
        if not ray.is_initialized():
            options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            if settings.ray_address:
                options["address"] = settings.ray_address
            else:
                options["num_cpus"] = settings.ray_num_cpus
                options["runtime_env"] = {"env_vars": {"PYTHONPATH": str(PROJECT_ROOT)}}
            ray.init(**options)
        from service.execution.executors.ray_task import run_job_stream

        self._remote = ray.remote(num_cpus=1, max_retries=0)(run_job_stream)
        self.database = database or Database(settings.database_url)
        self.store = ArtifactStore(settings.artifacts)
        self.registry = PolicyRegistry(self.database, self.store)
        self._jobs: dict[int, _RayJob] = {}
        self._exits: queue.Queue[WorkerExit] = queue.Queue()
        self._lock = threading.Lock()

    def free_slots(self) -> int:
        with self._lock:
            return self.settings.workers - len(self._jobs)

    def start(self, job: ClaimedJob) -> int | None:
        run_dir = self.store.confine(job.run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        stream = self._remote.options(
            num_returns="streaming", _generator_backpressure_num_objects=1, name=f"dualsys-job-{job.id}"
        ).remote(
            job.id,
            job.kind,
            job.spec,
            job.resolved,
            str(run_dir),
            job.resume,
            self.settings.heartbeat_interval_s,
        )
        entry = _RayJob(job=job, stream=stream)
        entry.thread = threading.Thread(target=self._follow, args=(entry, run_dir), daemon=True)
        with self._lock:
            self._jobs[job.id] = entry
        entry.thread.start()
        return None

    def _follow(self, entry: _RayJob, run_dir: Path) -> None:
        job = entry.job
        recorder = JobRecorder(
            self.database, job_id=job.id, owner=self.owner, attempt=job.attempt, run_dir=run_dir
        )
        code, detail = 0, f"ray task of job {job.id} finished"
        try:
            outcome = follow_job(
                self._events(entry),
                recorder=recorder,
                registry=self.registry,
                job=job,
                run_dir=run_dir,
                heartbeat_interval_s=self.settings.heartbeat_interval_s,
            )
            if outcome.kind == "lost":
                self._cancel_task(entry)
                code, detail = 4, f"ray task of job {job.id} lost its job"
            elif outcome.kind != "finished":
                code, detail = 1, f"ray task of job {job.id} ended without a result"
        except Exception as error:
            if entry.cancelled.is_set() or isinstance(error, self._cancel_errors()):
                code, detail = EXIT_CANCELLED, f"ray task of job {job.id} was cancelled"
            elif isinstance(error, self.ray.exceptions.RayTaskError):
                recorder.finish("failed", reason=_cause_message(error))
            else:  # the worker or node died: let the supervisor recover the job
                code, detail = 1, f"ray task of job {job.id} was lost ({_cause_message(error)})"
        self._exits.put(WorkerExit(job_id=job.id, returncode=code, detail=detail))

    def _events(self, entry: _RayJob) -> Iterator[dict[str, Any]]:
        """The task's events in order, with heartbeats from the driver until the first one arrives.

        Before its first event the task may be waiting for a CPU or for its worker process to start and import
        the job's libraries (over 20 s, the default heartbeat timeout, on a loaded 2-core machine, where the
        supervisor then took it for hung and cancelled it three times). It cannot send heartbeats before it
        runs; Ray vouches for it meanwhile (a worker that fails to start raises from ``ray.get``), so the
        driver sends them. From its first event on, the task's own heartbeats prove it alive.
        """
        while not self.ray.wait([entry.stream], timeout=self.settings.heartbeat_interval_s)[0]:
            if entry.cancelled.is_set():
                break
            yield {"type": "heartbeat"}
        for reference in entry.stream:
            yield self.ray.get(reference)

    def _cancel_errors(self) -> tuple[type[BaseException], ...]:
        exceptions = self.ray.exceptions
        return tuple(
            getattr(exceptions, name)
            for name in ("TaskCancelledError", "WorkerCrashedError")
            if hasattr(exceptions, name)
        )

    def _cancel_task(self, entry: _RayJob) -> None:
        entry.cancelled.set()
        with contextlib.suppress(Exception):
            self.ray.cancel(entry.stream, force=True)

    def poll(self) -> list[WorkerExit]:
        return drain_exits(self._exits, self._lock, self._jobs)

    def terminate(self, job_id: int) -> None:
        with self._lock:
            entry = self._jobs.get(job_id)
        if entry is not None and not entry.cancelled.is_set():
            self._cancel_task(entry)

    def running(self) -> set[int]:
        with self._lock:
            return set(self._jobs)

    def shutdown(self, grace_s: float) -> list[WorkerExit]:
        with self._lock:
            entries = list(self._jobs.values())
        for entry in entries:
            self._cancel_task(entry)
        deadline = time.monotonic() + grace_s + 5
        for entry in entries:
            if entry.thread is not None:
                entry.thread.join(timeout=max(0.0, deadline - time.monotonic()))
        return self.poll()
