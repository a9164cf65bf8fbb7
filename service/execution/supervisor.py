"""The supervisor: claims queued jobs, starts them on the executor, watches them, recovers lost ones.

It runs as one thread inside the service process. Each tick it
1. reaps ended workers: a worker that wrote its job's end is done; one that exited 75 (interrupted)
   is re-queued to resume; any other end (crash, SIGKILL) is recovered (see `recover`);
2. forwards cancel requests of its running jobs to the executor (SIGTERM, SIGKILL after a grace);
3. recovers running jobs whose heartbeat is older than `heartbeat_timeout_s` (a dead or hung
   worker, or a supervisor that died on another host);
4. claims queued jobs while the executor has free slots.

Recovery re-queues the job (with `resume` when its kind can resume and a checkpoint exists; without
one the lost attempt's rows and files are cleared and it starts over) until `max_attempts`, then
marks it failed with the reason; `DUALSYS_RECOVERY=fail` fails it at once.
At start-up, jobs left running by a dead supervisor on this host are recovered immediately;
at shutdown, the supervisor stops its workers and re-queues their jobs to resume.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import threading
import time
import uuid
from datetime import timedelta
from pathlib import Path

from sqlalchemy import select

from registry.artifact_store import ArtifactStore
from registry.database import Database
from service.database import job_store
from service.database.models import Job
from service.execution.executors import Executor, WorkerExit, make_executor
from service.execution.executors.base import EXIT_INTERRUPTED
from service.execution.job_kinds.catalogue import can_resume, job_kind
from service.settings import ServiceSettings

log = logging.getLogger("dualsys.service.supervisor")
STALE_CHECK_EVERY_S = 1.0
MIN_TICK_GAP_S = 0.05
"""A burst of submissions wakes the supervisor at most this often (it is one thread of the API process)."""


def make_owner_id() -> str:
    """`host:pid:random`, so a restarted service on the same host can tell its predecessor is dead."""
    return f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:8]}"


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def owner_is_dead_here(owner: str | None) -> bool:
    """True when `owner` names a supervisor process on this host that no longer exists."""
    if not owner:
        return True
    host, _, rest = owner.partition(":")
    pid_text = rest.partition(":")[0]
    return host == socket.gethostname() and pid_text.isdigit() and not pid_alive(int(pid_text))


def _is_our_worker(pid: int, run_dir: Path) -> bool:
    """A `service.execution.worker` process whose working directory is the job's run directory
    (Linux /proc)."""
    try:
        command = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        cwd = Path(os.readlink(f"/proc/{pid}/cwd"))
    except OSError:
        return False
    return b"service.execution.worker" in command and cwd == run_dir


class Supervisor:
    def __init__(
        self, settings: ServiceSettings, database: Database, executor: Executor | None = None
    ) -> None:
        self.settings = settings
        self.database = database
        self.store = ArtifactStore(settings.artifacts)
        self.owner = make_owner_id()
        self.executor = executor or make_executor(settings, self.owner, database)
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self._last_stale_check = 0.0

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        self.recover_orphans()
        self._thread = threading.Thread(target=self._loop, name="dualsys-supervisor", daemon=True)
        self._thread.start()

    def wake(self) -> None:
        """Look at the queue now (called after a submission or a cancel)."""
        self._wake.set()

    def wake_to_claim(self) -> None:
        """After a submission: look at the queue now if a slot is free (else the next exit will)."""
        if self.executor.free_slots() > 0:
            self._wake.set()

    def stop(self) -> None:
        """Stop claiming, stop the workers (they checkpoint on SIGTERM) and re-queue their jobs."""
        self._stopping.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=30)
        for exit_ in self.executor.shutdown(self.settings.cancel_grace_s):
            self._on_exit(exit_, shutting_down=True)

    def _loop(self) -> None:
        while not self._stopping.is_set():
            started = time.monotonic()
            try:
                self.tick()
            except Exception:  # the supervisor must outlive a failed tick (e.g. a locked database)
                log.exception("supervisor tick failed")
            self._wake.wait(self.settings.poll_interval_s)
            self._wake.clear()
            spare = MIN_TICK_GAP_S - (time.monotonic() - started)
            if spare > 0 and not self._stopping.is_set():
                time.sleep(spare)

    # ------------------------------------------------------------------ one round
    def tick(self) -> None:
        for exit_ in self.executor.poll():
            self._on_exit(exit_)
        self._forward_cancels()
        now = time.monotonic()
        if now - self._last_stale_check >= STALE_CHECK_EVERY_S:
            self._last_stale_check = now
            self._recover_stale()
        while not self._stopping.is_set() and self.executor.free_slots() > 0:
            claimed = job_store.claim_next_job(self.database, owner=self.owner)
            if claimed is None:
                break
            try:
                pid = self.executor.start(claimed)
            except Exception as error:
                log.exception("could not start job %s", claimed.id)
                self.recover(claimed.id, f"the executor could not start it: {error}", owner=self.owner)
                continue
            if pid is not None:
                job_store.set_worker_pid(self.database, job_id=claimed.id, owner=self.owner, pid=pid)

    def _on_exit(self, exit_: WorkerExit, *, shutting_down: bool = False) -> None:
        job = self._job(exit_.job_id)
        if job is None or job.status != "running" or job.owner != self.owner:
            return  # the worker wrote the end itself, or the job was taken over
        if job.cancel_requested:
            self.recover(job.id, "cancelled by request", owner=self.owner)
        elif exit_.returncode == EXIT_INTERRUPTED or shutting_down:
            reason = "the service stopped" if shutting_down else "its worker was interrupted"
            self.recover(job.id, reason, owner=self.owner, count_attempt=False, always_requeue=True)
        else:
            self.recover(job.id, f"{exit_.detail} before finishing", owner=self.owner)

    def _forward_cancels(self) -> None:
        running = self.executor.running()
        if not running:
            return
        with self.database.read() as session:
            flagged = session.scalars(
                select(Job.id).where(
                    Job.id.in_(running), Job.cancel_requested.is_(True), Job.status == "running"
                )
            ).all()
        for job_id in flagged:
            self.executor.terminate(job_id)

    def _recover_stale(self) -> None:
        stale = job_store.stale_running_jobs(
            self.database, older_than=timedelta(seconds=self.settings.heartbeat_timeout_s)
        )
        mine = self.executor.running()
        for job in stale:
            if job.id in mine and job.owner == self.owner:
                self.executor.terminate(job.id)  # hung worker: its exit is recovered when reaped
                continue
            self._kill_local_worker(job)
            self.recover(job.id, f"no heartbeat for {self.settings.heartbeat_timeout_s:g} s", owner=job.owner)

    def recover_orphans(self) -> None:
        """At start-up: recover jobs left running by a supervisor of this host that has died."""
        with self.database.read() as session:
            orphans = [j for j in job_store.running_jobs(session) if owner_is_dead_here(j.owner)]
        for job in orphans:
            self._kill_local_worker(job)
            self.recover(job.id, "the service that ran it stopped", owner=job.owner, count_attempt=False)

    def _kill_local_worker(self, job: Job) -> None:
        """Make sure no stray worker of a lost job still runs on this host before it is re-queued."""
        if (
            job.worker_pid
            and pid_alive(job.worker_pid)
            and _is_our_worker(job.worker_pid, self.store.confine(job.run_dir))
        ):
            with contextlib.suppress(OSError):
                os.kill(job.worker_pid, signal.SIGKILL)

    # ------------------------------------------------------------------ recovery
    def recover(
        self,
        job_id: int,
        reason: str,
        *,
        owner: str | None,
        count_attempt: bool = True,
        always_requeue: bool = False,
    ) -> str | None:
        """Re-queue or fail a lost job.

        `count_attempt=False` for interruptions that were not the job's fault (a service restart);
        `always_requeue` for a graceful shutdown, whatever `DUALSYS_RECOVERY` says.
        """
        job = self._job(job_id)
        if job is None:
            return None
        kind = job_kind(job.kind)
        run_dir = self.store.confine(job.run_dir)
        resume = can_resume(kind, run_dir)
        max_attempts = self.settings.max_attempts + (0 if count_attempt else job.attempt)
        status = job_store.recover_job(
            self.database,
            job_id=job_id,
            owner=owner,
            reason=reason,
            requeue=always_requeue or self.settings.recovery == "requeue",
            resume=resume,
            max_attempts=max_attempts,
        )
        if status == "queued" and not resume:
            job_store.reset_for_fresh_start(self.database, job_id=job_id, run_dir=run_dir)
            for child in run_dir.iterdir() if run_dir.is_dir() else []:
                if child.is_dir():
                    ArtifactStore.remove_tree(child)
                elif child.name != "worker.log":
                    child.unlink(missing_ok=True)
        if status is not None:
            log.warning("job %s %s: %s", job_id, status, reason)
            self._wake.set()
        return status

    def _job(self, job_id: int) -> Job | None:
        with self.database.read() as session:
            return session.get(Job, job_id)
