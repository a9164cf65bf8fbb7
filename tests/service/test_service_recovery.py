"""Lost workers and service restarts: jobs are recovered and resume with a continuous history.

Uses the `probe` kind (fast, resumable, JSON checkpoints); test_service_e2e_train.py does the
same with the real trainer.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable

from registry.database import Database
from service.database import job_store
from tests.utils.jobs import FINISHED, metrics, submit, wait_progress, wait_status
from tests.utils.live_service import LiveService, wait_for


def _assert_continuous(rows: list[dict], episodes: int) -> None:
    assert [r["episode"] for r in rows] == list(range(1, episodes + 1)), "lost or doubled metric rows"


def test_kill_9_worker_is_recovered_and_resumes(start_service: Callable[..., LiveService]) -> None:
    service = start_service()
    with service.client() as client:
        created = submit(client, "probe", episodes=25, interval_s=0.06)
        running = wait_progress(client, created["id"], 6)
        os.kill(running["worker_pid"], signal.SIGKILL)
        done = wait_status(client, created["id"], FINISHED)
        assert done["status"] == "succeeded", done
        assert done["attempt"] == 2 and done["summary"]["resumed"] is True
        assert "signal 9 (SIGKILL)" in done["reason"] and "resume" in done["reason"]
        rows = metrics(client, created["id"])
        _assert_continuous(rows, 25)
        attempts = [r["attempt"] for r in rows]
        assert (
            attempts[0] == 1 and attempts[-1] == 2 and attempts == sorted(attempts)
        )  # resumed, not restarted
        assert len({r["data"]["probe/pid"] for r in rows}) == 2


def test_service_crash_mid_job_resumes_on_restart(start_service: Callable[..., LiveService]) -> None:
    service = start_service()
    with service.client() as client:
        created = submit(client, "probe", episodes=25, interval_s=0.06)
        worker_pid = wait_progress(client, created["id"], 6)["worker_pid"]
    service.kill()  # SIGKILL: no shutdown code runs; the worker dies with it (PR_SET_PDEATHSIG)
    wait_for(lambda: not os.path.exists(f"/proc/{worker_pid}"), timeout=10, what="the orphaned worker to die")
    service.start()
    with service.client() as client:
        done = wait_status(client, created["id"], FINISHED)
        assert done["status"] == "succeeded" and done["attempt"] == 2, done
        assert "the service that ran it stopped" in done["reason"]
        _assert_continuous(metrics(client, created["id"]), 25)


def test_graceful_restart_requeues_then_resumes(start_service: Callable[..., LiveService]) -> None:
    service = start_service()
    with service.client() as client:
        created = submit(client, "probe", episodes=25, interval_s=0.06)
        wait_progress(client, created["id"], 6)
    assert service.stop() in (0, -signal.SIGTERM)  # uvicorn re-raises the signal after its shutdown
    # read the queue straight from the database, before a new service could pick the job up
    database = Database(service.settings["database_url"])
    parked = job_store.get_job(database, job_id=created["id"])
    database.dispose()
    assert parked.status == "queued" and parked.resume is True and parked.owner is None
    assert "the service stopped" in parked.reason
    service.start()
    with service.client() as client:
        done = wait_status(client, created["id"], FINISHED)
        assert done["status"] == "succeeded" and done["summary"]["resumed"] is True
        _assert_continuous(metrics(client, created["id"]), 25)


def test_hung_worker_is_detected_by_heartbeat(start_service: Callable[..., LiveService]) -> None:
    service = start_service(heartbeat_timeout_s=2, cancel_grace_s=1)
    with service.client() as client:
        created = submit(client, "probe", episodes=20, interval_s=0.05)
        pid = wait_progress(client, created["id"], 4)["worker_pid"]
        os.kill(pid, signal.SIGSTOP)  # alive but silent: only the missing heartbeat shows it
        done = wait_status(client, created["id"], FINISHED, timeout=60)
        assert done["status"] == "succeeded" and done["attempt"] == 2, done
        _assert_continuous(metrics(client, created["id"]), 20)


def test_recovery_fail_policy_marks_the_job_failed_with_the_reason(
    start_service: Callable[..., LiveService],
) -> None:
    service = start_service(recovery="fail")
    with service.client() as client:
        created = submit(client, "probe", episodes=200, interval_s=0.05)
        pid = wait_progress(client, created["id"], 2)["worker_pid"]
        os.kill(pid, signal.SIGKILL)
        done = wait_status(client, created["id"], FINISHED)
        assert done["status"] == "failed"
        assert done["reason"] == f"worker process {pid} ended with signal 9 (SIGKILL) before finishing"
