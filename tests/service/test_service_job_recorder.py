"""The recorder's exactly-once metric history and ownership checks."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from registry.database import Database
from service.database import job_store
from service.database.migrate import upgrade_service
from service.database.models import JobMetric
from service.errors import LostOwnership
from service.execution.job_recorder import JobRecorder, jsonable


@pytest.fixture()
def database(tmp_path: Path) -> Iterator[Database]:
    db = Database(f"sqlite:///{tmp_path / 'rec.db'}")
    upgrade_service(db.engine)
    yield db
    db.dispose()


def _episodes(database: Database, job_id: int) -> list[tuple[int, int]]:
    with database.read() as session:
        rows = session.query(JobMetric).filter_by(job_id=job_id).order_by(JobMetric.episode).all()
        return [(r.episode, r.attempt) for r in rows]


def test_resumed_attempt_replaces_rows_after_its_checkpoint(database: Database, tmp_path: Path) -> None:
    job, _ = job_store.create_job(database, kind="probe", spec={}, resolved={}, progress_total=None)
    first = job_store.claim_next_job(database, owner="a")
    recorder = JobRecorder(database, job_id=job.id, owner="a", attempt=first.attempt, run_dir=tmp_path)
    for episode in range(1, 8):  # the lost attempt got to episode 7, its checkpoint was at 5
        recorder.record_metric({"episode": episode, "global_step": episode * 10})
    job_store.recover_job(
        database, job_id=job.id, owner="a", reason="x", requeue=True, resume=True, max_attempts=3
    )
    second = job_store.claim_next_job(database, owner="b")
    resumed = JobRecorder(database, job_id=job.id, owner="b", attempt=second.attempt, run_dir=tmp_path)
    resumed.record_metric({"episode": 6, "global_step": 60})
    assert _episodes(database, job.id) == [(1, 1), (2, 1), (3, 1), (4, 1), (5, 1), (6, 2)]  # 7 dropped
    for episode in range(7, 11):
        resumed.record_metric({"episode": episode, "global_step": episode * 10})
    assert [e for e, _ in _episodes(database, job.id)] == list(range(1, 11))
    assert resumed.finish("succeeded", summary={"loss": float("nan")})
    assert job_store.get_job(database, job_id=job.id).summary == {"loss": None}


def test_a_worker_that_lost_its_job_cannot_write(database: Database, tmp_path: Path) -> None:
    job, _ = job_store.create_job(database, kind="probe", spec={}, resolved={}, progress_total=None)
    job_store.claim_next_job(database, owner="a")
    stale = JobRecorder(database, job_id=job.id, owner="a", attempt=1, run_dir=tmp_path)
    job_store.recover_job(
        database, job_id=job.id, owner="a", reason="x", requeue=True, resume=True, max_attempts=3
    )
    job_store.claim_next_job(database, owner="b")
    with pytest.raises(LostOwnership):
        stale.record_metric({"episode": 1})
    assert stale.heartbeat().still_owner is False
    assert stale.finish("succeeded") is False
    assert job_store.get_job(database, job_id=job.id).owner == "b"


def test_jsonable_converts_numpy_and_non_finite_values() -> None:
    value = jsonable(
        {"a": np.float32(1.5), "b": np.int64(3), "c": math.inf, "d": np.array([1, 2]), "e": (1, None)}
    )
    assert value == {"a": 1.5, "b": 3, "c": None, "d": [1, 2], "e": [1, None]}
