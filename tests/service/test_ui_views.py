"""What the jobs table reads of a job: "current success" from a real SQLite queue written by the real
recorder (greedy evaluation first, else recent training episodes; incremental reads; a resumed attempt
starts over), the method/task/reward/level/seed columns from resolved configs and specs (a level only for
NicoGrasp), and the diagnostics panels' legends (names a person reads, never metrics.csv keys)."""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path
from types import SimpleNamespace

import pytest

from registry.database import Database
from service.database import job_store
from service.database.migrate import upgrade_service
from service.execution.job_recorder import JobRecorder
from service.ui.views import (
    SuccessTracker,
    age_text,
    diagnostic_groups,
    job_env,
    job_level,
    job_method,
    job_reward,
    job_row,
    summary_success,
)


@pytest.fixture()
def database(tmp_path: Path) -> Iterator[Database]:
    db = Database(f"sqlite:///{tmp_path / 'ui.db'}")
    upgrade_service(db.engine)
    yield db
    db.dispose()


def _row(database: Database, job_id: int):  # type: ignore[no-untyped-def]
    return job_store.get_job(database, job_id=job_id)


def test_current_success_prefers_greedy_evaluation_and_reads_only_new_rows(
    database: Database, tmp_path: Path
) -> None:
    job, _ = job_store.create_job(database, kind="train", spec={}, resolved={}, progress_total=100)
    claimed = job_store.claim_next_job(database, owner="a")
    recorder = JobRecorder(database, job_id=job.id, owner="a", attempt=claimed.attempt, run_dir=tmp_path)
    tracker = SuccessTracker()
    for episode in range(1, 5):  # 1 of 4 training episodes succeeded, no evaluation yet
        recorder.record_metric(
            {"episode": episode, "charts/success": int(episode == 2), "eval/success_rate": float("nan")}
        )
    first = tracker.current(database, [_row(database, job.id)])[job.id]
    assert (first.source, first.value, first.note) == ("train", 0.25, "training episodes, last 4")

    recorder.record_metric({"episode": 5, "charts/success": 1, "eval/success_rate": 0.6})
    recorder.record_metric({"episode": 6, "charts/success": 0})
    second = tracker.current(database, [_row(database, job.id)])[job.id]
    assert (second.source, second.value) == ("eval", 0.6)
    assert second.note == "greedy evaluation at episode 5"
    assert tracker._seen[job.id].episode == 6 and len(tracker._seen[job.id].successes) == 6

    # the worker is lost; the resumed attempt rewrites episode 5 on: the tracker starts over
    job_store.recover_job(
        database, job_id=job.id, owner="a", reason="x", requeue=True, resume=True, max_attempts=3
    )
    again = job_store.claim_next_job(database, owner="b")
    resumed = JobRecorder(database, job_id=job.id, owner="b", attempt=again.attempt, run_dir=tmp_path)
    resumed.record_metric({"episode": 5, "charts/success": 0, "eval/success_rate": 0.2})
    third = tracker.current(database, [_row(database, job.id)])[job.id]
    assert (third.value, third.note) == (0.2, "greedy evaluation at episode 5")
    assert len(tracker._seen[job.id].successes) == 5

    assert resumed.finish("succeeded", summary={"success_rate": 0.9, "train_success_rate_last100": 0.5})
    done = tracker.current(database, [_row(database, job.id)])[job.id]
    assert (done.source, done.value, done.note) == ("eval", 0.9, "greedy evaluation (final)")
    assert job.id not in tracker._seen  # finished jobs are forgotten


def test_summary_without_evaluation_falls_back_to_training_success() -> None:
    assert summary_success({"success_rate": None, "train_success_rate_last100": 0.3}).source == "train"
    assert summary_success({"episodes": 3}) is None and summary_success(None) is None


def test_columns_come_from_the_resolved_config_then_the_spec() -> None:
    now = datetime.now(UTC)
    train = SimpleNamespace(
        id=1,
        kind="train",
        status="running",
        cancel_requested=False,
        progress_episode=3,
        progress_total=10,
        created_at=now - timedelta(minutes=5),
        reason=None,
        summary=None,
        spec={"algo": "ddpg", "ac": "cacla", "overrides": {}},
        resolved={
            "config": {
                "run": {"algo": "ddpg", "seed": 0},
                "env": {"reward_mode": "dense", "level": "hard"},
                "agent": {"ac": "cacla"},
            }
        },
    )
    row = job_row(train, None, now)
    assert (row["method"], row["reward"], row["level"], row["seed"]) == ("ddpg (cacla)", "dense", "hard", 0)
    assert (row["fraction"], row["age"]) == (0.3, "5 min")
    older = SimpleNamespace(
        **{
            **vars(train),
            "resolved": {"config": {"run": {"algo": "i2a"}, "env": {}}},
            "spec": {"overrides": {"env.level": "paper"}},
        }
    )
    assert job_level(older) == "paper" and job_method(older) == "i2a"
    plain = SimpleNamespace(**{**vars(train), "resolved": {}, "spec": {"algo": "i2a"}})
    assert job_level(plain) == "released"
    probe = SimpleNamespace(**{**vars(train), "kind": "probe", "resolved": {}, "spec": {"episodes": 3}})
    assert job_level(probe) is None and job_method(probe) is None
    assert (
        age_text(now - timedelta(seconds=5), now) == "5 s" and age_text(now - timedelta(days=3), now) == "3 d"
    )


def test_another_task_shows_its_own_reward_and_no_nicograsp_level() -> None:
    """A MountainCar job's config still holds NicoGrasp's defaults (`env.level: released`, `reward_mode`):
    the table and the card show the task, its own reward, and no level."""
    mountain_car = SimpleNamespace(
        kind="train",
        spec={"algo": "im2c", "ac": "sac", "overrides": {"env.id": "MountainCarContinuous-v0"}},
        resolved={
            "config": {
                "run": {"algo": "im2c"},
                "env": {"id": "MountainCarContinuous-v0", "reward_mode": "dense", "level": "released"},
            }
        },
    )
    assert job_env(mountain_car) == "MountainCarContinuous-v0"
    assert (job_level(mountain_car), job_reward(mountain_car)) == (None, "task")
    queued = SimpleNamespace(kind="train", spec=mountain_car.spec, resolved={})  # from the spec alone
    assert job_env(queued) == "MountainCarContinuous-v0"
    assert (job_level(queued), job_reward(queued)) == (None, "task")
    grasp = SimpleNamespace(
        kind="train", spec={"reward": "sparse"}, resolved={"config": {"env": {"level": "hard"}}}
    )
    assert (job_env(grasp), job_level(grasp), job_reward(grasp)) == ("dualsys/NicoGrasp-v0", "hard", "sparse")
    probe = SimpleNamespace(kind="probe", spec={"episodes": 3}, resolved={})
    assert (job_env(probe), job_level(probe), job_reward(probe)) == (None, None, None)


def test_every_diagnostics_legend_is_a_name_not_a_metrics_key() -> None:
    groups = diagnostic_groups()
    legends = {key: label for group in groups for key, label in group["series"]}
    assert "charts/start_value" in legends and "dual/mb_decisions" in legends
    raw = {key: label for key, label in legends.items() if label == key or "/" in label}
    assert not raw, raw
    assert legends["charts/start_value"] == "critic's value of the start state"
