"""TensorBoard event files (`run.tensorboard`, `dualsys train --tensorboard`): read back with TensorBoard's
own event reader, they hold one scalar series per metrics.csv column at the env steps, for a train job
run by a real service and for a run resumed after a lost session (each episode shown once).

Here beside the service tests (the writer lives in core/runs/tensorboard_log.py) because the job path is
the one a lab uses; the resume case drives `dualsys train` itself."""

from __future__ import annotations

import csv
import io
import math
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dualsys_cli.main import app
from tests.utils.experiment_files import TINY_NETS
from tests.utils.jobs import submit, wait_status
from tests.utils.live_service import LiveService

event_accumulator = pytest.importorskip(
    "tensorboard.backend.event_processing.event_accumulator", reason="tensorboard is in the dev extra"
)

TINY = {
    **TINY_NETS,
    "env.max_steps": 5,
    "run.eval_every": 2,
    "run.eval_episodes": 1,
    "run.num_threads": 1,
    "agent.learning_starts": 5,
    "agent.batch_size": 8,
}
COUNTERS = {"episode", "global_step"}


def _scalars(folder: Path) -> dict[str, list[tuple[int, float]]]:
    """Every scalar series in `folder`'s event files: tag → [(step, value)] (TensorBoard's reader)."""
    reader = event_accumulator.EventAccumulator(str(folder), size_guidance={event_accumulator.SCALARS: 0})
    reader.Reload()
    return {tag: [(e.step, e.value) for e in reader.Scalars(tag)] for tag in reader.Tags()["scalars"]}


def _csv_series(text: str) -> dict[str, list[tuple[int, float]]]:
    """metrics.csv as tag → [(global_step, value)] for its finite values."""
    rows = list(csv.DictReader(io.StringIO(text)))
    series: dict[str, list[tuple[int, float]]] = {}
    for row in rows:
        for key, raw in row.items():
            if key in COUNTERS or raw in ("", None):
                continue
            value = float(raw)
            if math.isfinite(value):
                series.setdefault(key, []).append((int(row["global_step"]), value))
    return series


def _same(logged: dict, expected: dict) -> None:
    assert set(logged) == set(expected), set(logged) ^ set(expected)
    for tag, points in expected.items():
        assert [s for s, _ in logged[tag]] == [s for s, _ in points], tag
        assert all(
            math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6)
            for (_, a), (_, b) in zip(logged[tag], points, strict=True)
        ), tag


@pytest.mark.timeout(600)
def test_a_train_job_writes_tensorboard_scalars_named_as_metrics_csv(
    start_service: Callable[..., LiveService], tmp_path: Path
) -> None:
    service = start_service(workers=1)
    with service.client(timeout=180) as client:
        overrides = {**TINY, "run.tensorboard": True}
        created = submit(
            client, "train", algo="ddpg", reward="dense", seed=2, episodes=4, overrides=overrides
        )
        done = wait_status(client, created["id"], {"succeeded", "failed"}, timeout=500)
        assert done["status"] == "succeeded", done["reason"]
        names = [a["name"] for a in client.get(f"/jobs/{created['id']}/artifacts").json()["data"]]
        events = [n for n in names if n.startswith("events.out.tfevents.")]
        assert len(events) == 1, names
        folder = tmp_path / "downloaded"
        folder.mkdir()
        for name in events:  # through the REST download, as a lab member would fetch them
            (folder / name).write_bytes(client.get(f"/jobs/{created['id']}/artifacts/{name}").content)
        metrics_csv = client.get(f"/jobs/{created['id']}/artifacts/metrics.csv").text
    logged = _scalars(folder)
    expected = _csv_series(metrics_csv)
    assert {"charts/episodic_return", "charts/success", "eval/success_rate", "losses/critic"} <= set(logged)
    _same(logged, expected)
    assert [s for s, _ in logged["eval/success_rate"]] == [s for s, _ in expected["eval/success_rate"]]


@pytest.mark.timeout(600)
def test_a_resumed_run_shows_each_episode_once(tmp_path: Path) -> None:
    run = tmp_path / "run"
    sets = [arg for key, value in TINY.items() for arg in ("--set", f"{key}={_text(value)}")]
    runner = CliRunner()

    def train(*args: str) -> None:
        result = runner.invoke(app, ["train", "--algo", "ddpg", "--seed", "1", *sets, *args])
        assert result.exit_code == 0, result.output

    train("--episodes", "2", "--out", str(run), "--tensorboard")
    checkpoint_at_2 = (run / "checkpoints" / "latest.pt").read_bytes()
    train("--resume", str(run), "--episodes", "4")  # episodes 3 and 4 ...
    # ... are lost: the service (say) died after writing them but before their checkpoint
    (run / "checkpoints" / "latest.pt").write_bytes(checkpoint_at_2)
    train("--resume", str(run), "--episodes", "5")  # replays 3 and 4 (other values), then 5
    assert len(list(run.glob("events.out.tfevents.*"))) == 3
    logged = _scalars(run)
    expected = _csv_series((run / "metrics.csv").read_text())
    assert len(expected["charts/episodic_return"]) == 5
    _same(logged, expected)  # the lost session's 3 and 4 are purged; each step appears once
    assert not any(name.startswith("events.") for name in _hidden(run))

    without = tmp_path / "plain"
    train("--episodes", "1", "--out", str(without))
    assert not list(without.glob("events.out.tfevents.*"))  # off by default
    shutil.rmtree(without)


def _text(value: object) -> str:
    if isinstance(value, list):
        return ",".join(str(v) for v in value)
    return str(value).lower() if isinstance(value, bool) else str(value)


def _hidden(folder: Path) -> list[str]:
    return [p.name for p in folder.iterdir() if p.name.startswith(".")]
