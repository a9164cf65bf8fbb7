"""The Ray executor: a local Ray (`ray.init(num_cpus=1)`) runs jobs as tasks; metrics reach the database."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import pytest

ray = pytest.importorskip("ray", reason="Ray is an optional extra (pip install 'dualsys[ray]')")

from registry.database import Database  # noqa: E402
from service.database import job_store  # noqa: E402
from service.database.migrate import upgrade_service  # noqa: E402
from service.database.models import JobMetric  # noqa: E402
from service.execution.executors.ray_executor import RayExecutor  # noqa: E402
from service.execution.supervisor import Supervisor  # noqa: E402
from service.settings import ServiceSettings  # noqa: E402
from tests.utils.experiment_files import TINY_NETS  # noqa: E402
from tests.utils.live_service import wait_for  # noqa: E402


@pytest.fixture(scope="module")
def local_ray() -> Iterator[None]:
    root = str(Path(__file__).resolve().parents[2])
    ray.init(
        num_cpus=1,
        include_dashboard=False,
        log_to_driver=False,
        runtime_env={"env_vars": {"PYTHONPATH": root}},
    )
    yield
    ray.shutdown()


def _supervisor(tmp_path: Path, **settings_changes: float) -> Supervisor:
    settings = ServiceSettings(
        **{
            "database_url": f"sqlite:///{tmp_path / 'ray.db'}",
            "artifacts": tmp_path / "artifacts",
            "executor": "ray",
            "workers": 1,
            "poll_interval_s": 0.1,
            "heartbeat_interval_s": 0.5,
            **settings_changes,
        }
    )
    database = Database(settings.database_url)
    upgrade_service(database.engine)
    running = Supervisor(settings, database)
    assert isinstance(running.executor, RayExecutor)
    running.start()
    return running


@pytest.fixture()
def supervisor(local_ray: None, tmp_path: Path) -> Iterator[Supervisor]:
    running = _supervisor(tmp_path)
    yield running
    running.stop()
    running.database.dispose()


def _submit(supervisor: Supervisor, kind: str, spec: dict) -> int:
    job, _ = job_store.create_job(supervisor.database, kind=kind, spec=spec, resolved={}, progress_total=None)
    supervisor.wake()
    return job.id


def _finished(supervisor: Supervisor, job_id: int, timeout: float = 600):  # type: ignore[no-untyped-def]
    """The job's final record; the deadline only bounds a hang (a loaded 2-core machine starts Ray slowly:
    a tiny job took over 120 s there while two training runs shared the cores)."""
    def done():  # type: ignore[no-untyped-def]
        job = job_store.get_job(supervisor.database, job_id=job_id)
        return job if job.status in ("succeeded", "failed", "cancelled") else None

    return wait_for(done, timeout=timeout, interval=0.2, what=f"ray job {job_id}")


def test_ray_task_runs_a_job_and_metrics_reach_the_database(supervisor: Supervisor) -> None:
    job_id = _submit(supervisor, "probe", {"episodes": 4, "interval_s": 0.05})
    job = _finished(supervisor, job_id)
    assert job.status == "succeeded", job.reason
    assert job.summary == {"episodes": 4, "resumed": False}
    with supervisor.database.read() as session:
        rows = session.query(JobMetric).filter_by(job_id=job_id).order_by(JobMetric.episode).all()
    assert [r.episode for r in rows] == [1, 2, 3, 4]
    assert rows[0].data["probe/pid"] != __import__("os").getpid()  # ran in a Ray worker process
    assert (supervisor.store.root / "jobs" / str(job_id) / "checkpoints" / "latest.json").is_file()


def test_ray_job_failure_and_cancel(supervisor: Supervisor) -> None:
    failing = _submit(supervisor, "probe", {"episodes": 3, "interval_s": 0, "fail_at_episode": 2})
    job = _finished(supervisor, failing)
    assert job.status == "failed" and "probe failed at episode 2" in job.reason
    long = _submit(supervisor, "probe", {"episodes": 1000, "interval_s": 0.05})
    wait_for(
        lambda: job_store.get_job(supervisor.database, job_id=long).progress_episode >= 2,
        timeout=60,
        what="the long ray job to make progress",
    )
    job_store.request_cancel(supervisor.database, job_id=long)
    supervisor.wake()
    assert _finished(supervisor, long).status == "cancelled"


def test_ray_runs_a_tiny_training_job(supervisor: Supervisor) -> None:
    overrides = {
        **TINY_NETS,
        "env.max_steps": 5,
        "run.eval_every": 0,
        "run.eval_episodes": 1,
        "run.num_threads": 1,
        "agent.learning_starts": 5,
        "agent.batch_size": 8,
    }
    job_id = _submit(supervisor, "train", {"algo": "ddpg", "episodes": 3, "overrides": overrides})
    job = _finished(supervisor, job_id)
    assert job.status == "succeeded", job.reason
    with supervisor.database.read() as session:
        episodes = [
            r.episode for r in session.query(JobMetric).filter_by(job_id=job_id).order_by(JobMetric.episode)
        ]
    assert episodes == [1, 2, 3]
    assert (supervisor.store.root / "jobs" / str(job_id) / "checkpoints" / "best.pt").is_file()


def test_ray_records_are_committed_before_the_job_checkpoints_them(supervisor: Supervisor) -> None:
    """Sampled invariant: whenever the checkpoint says episode k, the database already holds row k."""
    import json

    job_id = _submit(supervisor, "probe", {"episodes": 30, "interval_s": 0.02})
    checkpoint = supervisor.store.root / "jobs" / str(job_id) / "checkpoints" / "latest.json"
    samples = 0
    while job_store.get_job(supervisor.database, job_id=job_id).status in ("queued", "running"):
        try:
            episode = json.loads(checkpoint.read_text())["episode"]
        except (OSError, ValueError):
            continue
        with supervisor.database.read() as session:
            stored = session.query(JobMetric).filter_by(job_id=job_id).count()
        assert stored >= episode, (stored, episode)
        samples += 1
    assert samples > 0 and _finished(supervisor, job_id).status == "succeeded"


def test_a_task_waiting_longer_than_the_heartbeat_timeout_to_start_is_not_taken_for_hung(
    local_ray: None, tmp_path: Path
) -> None:
    """The only CPU is busy for 4 s, four heartbeat timeouts: the job's task waits for it without running, and
    so without sending heartbeats (as a cold worker importing torch on a loaded machine does). It must run
    then, at its first attempt, not be cancelled as hung."""

    @ray.remote(num_cpus=1)
    def hold_the_cpu(seconds: float) -> None:
        time.sleep(seconds)

    blocker = hold_the_cpu.remote(4.0)
    ray.wait([blocker], timeout=0.5)  # scheduled and holding the CPU before the job arrives
    running = _supervisor(tmp_path, heartbeat_interval_s=0.2, heartbeat_timeout_s=1.0)
    try:
        job_id = _submit(running, "probe", {"episodes": 2, "interval_s": 0.05})
        job = _finished(running, job_id)
        assert job.status == "succeeded", job.reason
        assert job.attempt == 1
    finally:
        running.stop()
        running.database.dispose()
        ray.get(blocker)
