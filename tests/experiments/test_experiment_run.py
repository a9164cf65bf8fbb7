"""Running experiments on local worker processes: the grid, skip on rerun, resume after a SIGKILLed
worker with a continuous metrics.csv, refusal of changed settings, time-based checkpoints."""

from __future__ import annotations

import itertools
import json
import os
import re
import signal
import time

import pytest
import yaml
from typer.testing import CliRunner

from core.config import load_config
from core.experiments import cell_state, load_experiment, run_experiment
from core.runs.run_dir import load_checkpoint
from core.runs.trainer import train
from dualsys_cli.main import app
from tests.experiments.conftest import tiny_experiment_data
from tests.utils.run_dirs import metrics_rows

# These tests spawn worker processes that train real (tiny) cells: a few CPU-seconds each, but on a shared
# 2-core machine under `nice -n 19` they can wait many minutes for a core, past the suite's 600 s default.
SLOW_MACHINE_TIMEOUT_S = 1800

RUN_FILES = (
    "config.yaml",
    "command.txt",
    "metrics.csv",
    "summary.json",
    "learning_curve.png",
    "checkpoints/latest.pt",
    "checkpoints/best.pt",
)


def rows(run_dir) -> list[dict[str, str]]:
    return metrics_rows(run_dir)


@pytest.mark.timeout(SLOW_MACHINE_TIMEOUT_S)
def test_grid_runs_on_two_workers_and_a_second_run_skips_every_cell(tmp_path, write_experiment):
    path = write_experiment()
    out = tmp_path / "out"
    first = CliRunner().invoke(  # a narrow "terminal": log lines must not wrap at its width
        app,
        ["experiment", "run", str(path), "--out", str(out), "--workers", "2", "--json"],
        env={"COLUMNS": "40"},
    )
    assert first.exit_code == 0, first.output
    outcome = json.loads(first.stdout.strip().splitlines()[-1])
    assert outcome["cells"] == 4 and len(outcome["done"]) == 4 and outcome["complete"]
    root = out / "tiny"
    assert yaml.safe_load((root / "experiment.yaml").read_text())["name"] == "tiny"
    for label in ("DDPG", "DDPG+IM2C"):
        for seed in (0, 1):
            cell = root / label / "dense" / f"seed-{seed}"
            for name in RUN_FILES:
                assert (cell / name).is_file(), cell / name
            summary = json.loads((cell / "summary.json").read_text())
            assert summary["stopped"] is False and summary["seed"] == seed
            assert summary["steps"] >= 100 and summary["steps"] < 100 + 5  # the step budget, to the episode
            config = yaml.safe_load((cell / "config.yaml").read_text())
            assert config["run"]["steps"] == 100 and config["run"]["episodes"] is None
            assert config["run"]["num_threads"] == 1
    # stderr is no terminal here (as under nohup): the log has one line per cell that starts and finishes.
    log = first.stderr.splitlines()
    assert "tiny [0/4 done] 4 cells, 0 already done" in log[0]
    for key in outcome["done"]:  # one line each, however long: a log is not wrapped at a terminal's width
        started = rf"\] {re.escape(key)} started \(pid \d+\)$"
        assert sum(bool(re.search(started, line)) for line in log) == 1, log
        assert sum(f"] {key} done at step " in line for line in log) == 1, log
    assert "[4/4 done]" in [line for line in log if " done at step " in line][-1]
    written = {p: p.stat().st_mtime_ns for p in root.glob("*/*/seed-*/*") if p.is_file()}
    second = CliRunner().invoke(app, ["experiment", "run", str(path), "--out", str(out), "--json"])
    assert second.exit_code == 0, second.output
    again = json.loads(second.stdout.strip().splitlines()[-1])
    assert sorted(again["skipped"]) == sorted(outcome["done"]) and again["done"] == []
    # no cell retrained: no worker started, no file of a cell written again
    assert {p: p.stat().st_mtime_ns for p in written} == written
    assert "[4/4 done] 4 cells, 4 already done" in second.stderr and " started " not in second.stderr


@pytest.mark.timeout(SLOW_MACHINE_TIMEOUT_S)
def test_changed_settings_of_a_finished_cell_are_refused(tmp_path, write_experiment):
    out = tmp_path / "out"
    spec = load_experiment(write_experiment(methods=[{"label": "DDPG", "algo": "ddpg"}], seeds=1))
    assert run_experiment(spec, out, workers=1).complete
    stored = (out / "tiny" / "experiment.yaml").read_text()
    changed = write_experiment(methods=[{"label": "DDPG", "algo": "ddpg"}], seeds=1, steps=120)
    result = CliRunner().invoke(app, ["experiment", "run", str(changed), "--out", str(out)])
    assert result.exit_code == 2
    assert result.stderr.strip().count("\n") == 0
    assert "DDPG/dense/seed-0" in result.stderr and "run.steps was 100" in result.stderr
    assert (out / "tiny" / "experiment.yaml").read_text() == stored  # nothing written
    # Settings that do not change results (checkpoint cadence) may change; a new seed extends the grid.
    extended = write_experiment(
        methods=[{"label": "DDPG", "algo": "ddpg"}],
        seeds=2,
        overrides={**tiny_experiment_data()["overrides"], "run.checkpoint_every_s": 30},
    )
    grown = run_experiment(load_experiment(extended), out, workers=1)
    assert grown.skipped == ["DDPG/dense/seed-0"] and grown.done == ["DDPG/dense/seed-1"]


@pytest.mark.timeout(SLOW_MACHINE_TIMEOUT_S)
def test_only_runs_the_named_methods_cells_and_leaves_the_rest_for_later(tmp_path, write_experiment):
    path = write_experiment(seeds=1)
    out = tmp_path / "out"
    unknown = CliRunner().invoke(app, ["experiment", "run", str(path), "--out", str(out), "--only", "PPO"])
    assert unknown.exit_code == 2 and "--only: PPO (the methods are: DDPG, DDPG+IM2C)" in unknown.stderr
    assert not (out / "tiny").exists()  # refused before anything was written
    first = CliRunner().invoke(
        app, ["experiment", "run", str(path), "--out", str(out), "--only", "DDPG", "--workers", "1", "--json"]
    )
    assert first.exit_code == 0, first.output
    outcome = json.loads(first.stdout.strip().splitlines()[-1])
    assert outcome["cells"] == 1 and outcome["done"] == ["DDPG/dense/seed-0"] and outcome["complete"]
    assert cell_state(out / "tiny" / "DDPG+IM2C" / "dense" / "seed-0") == "new"
    rest = run_experiment(load_experiment(path), out, workers=1)
    assert rest.skipped == ["DDPG/dense/seed-0"] and rest.done == ["DDPG+IM2C/dense/seed-0"]


@pytest.mark.timeout(SLOW_MACHINE_TIMEOUT_S)
def test_a_killed_worker_leaves_its_cell_resumable_with_a_continuous_metrics_csv(tmp_path, write_experiment):
    overrides = {**tiny_experiment_data()["overrides"], "run.checkpoint_every": 5}
    spec = load_experiment(
        write_experiment(
            methods=[{"label": "DDPG", "algo": "ddpg"}],
            seeds=2,
            steps=200,
            eval_every=20,
            overrides=overrides,
        )
    )
    out = tmp_path / "out"
    victim = "DDPG/dense/seed-0"
    run_dir = out / "tiny" / "DDPG" / "dense" / "seed-0"
    killed: dict[str, int] = {}

    def kill_mid_run(progress) -> None:
        state = progress.cells[victim]
        if killed or state.status != "running" or state.pid is None or state.episode < 8:
            return
        if (run_dir / "checkpoints" / "latest.pt").is_file():
            os.kill(state.pid, signal.SIGKILL)
            killed["episode"] = state.episode

    first = run_experiment(spec, out, workers=2, progress_callback=kill_mid_run)
    assert killed, "the cell finished before it could be killed"
    assert list(first.interrupted) == [victim] and "died" in first.interrupted[victim]
    assert first.done == ["DDPG/dense/seed-1"]  # the other worker went on
    assert cell_state(run_dir) == "partial"
    checkpoint_episode = load_checkpoint(run_dir / "checkpoints" / "latest.pt")["counters"]["episode"]
    assert 0 < checkpoint_episode < 40 and checkpoint_episode % 5 == 0
    # Rows written after the checkpoint (usually some: checkpoints every 5 episodes) are dropped on resume.
    assert len(rows(run_dir)) >= checkpoint_episode

    second = run_experiment(spec, out, workers=2)
    assert second.done == [victim] and second.skipped == ["DDPG/dense/seed-1"] and second.complete
    table = rows(run_dir)
    episodes = [int(row["episode"]) for row in table]
    assert episodes == list(range(1, len(episodes) + 1))  # no duplicated, no missing episode
    steps = [int(row["global_step"]) for row in table]
    assert all(b > a for a, b in itertools.pairwise(steps)) and steps[-1] >= 200
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["episodes"] == len(episodes) and summary["steps"] == steps[-1]
    commands = (run_dir / "command.txt").read_text().splitlines()
    assert len(commands) == 2  # started, then resumed from the checkpoint


@pytest.mark.timeout(SLOW_MACHINE_TIMEOUT_S)
def test_leftovers_without_a_checkpoint_are_started_again(tmp_path, write_experiment):
    spec = load_experiment(write_experiment(methods=[{"label": "DDPG", "algo": "ddpg"}], seeds=1))
    run_dir = tmp_path / "out" / "tiny" / "DDPG" / "dense" / "seed-0"
    run_dir.mkdir(parents=True)
    (run_dir / "metrics.csv").write_text("episode,global_step\n1,5\n2,10\n")  # killed before a checkpoint
    result = run_experiment(spec, tmp_path / "out", workers=1)
    assert result.done == ["DDPG/dense/seed-0"]
    assert [int(row["episode"]) for row in rows(run_dir)][:3] == [1, 2, 3]
    assert rows(run_dir)[0]["charts/episodic_return"] != ""


def test_trainer_checkpoints_by_time_as_well_as_by_episode(tmp_path):
    overrides = [f"{key}={value}" for key, value in tiny_experiment_data()["overrides"].items()]
    overrides = [item.replace("[4, 4]", "4,4") for item in overrides]
    seen: list[int | None] = []

    def watch(run_dir):
        def on_episode(record):
            latest = run_dir / "checkpoints" / "latest.pt"
            seen.append(load_checkpoint(latest)["counters"]["episode"] if latest.is_file() else None)

        return on_episode

    by_time = load_config(
        "default", [*overrides, "run.episodes=4", "run.checkpoint_every=1000", "run.checkpoint_every_s=1e-9"]
    )
    train(by_time, tmp_path / "timed", on_episode=watch(tmp_path / "timed"), command="test")
    assert seen == [None, 1, 2, 3]  # a checkpoint after every episode: the interval has always passed
    seen.clear()
    by_episode = load_config(
        "default", [*overrides, "run.episodes=4", "run.checkpoint_every=1000", "run.checkpoint_every_s=none"]
    )
    train(by_episode, tmp_path / "episodic", on_episode=watch(tmp_path / "episodic"), command="test")
    assert seen == [None, None, None, None]


@pytest.mark.timeout(SLOW_MACHINE_TIMEOUT_S)
def test_ctrl_c_stops_every_cell_resumably_and_a_rerun_finishes(tmp_path, write_experiment):
    """SIGINT to the command's process group, as a terminal's Ctrl-C sends it: exit 130, every started
    cell stopped with a checkpoint; the same command again completes the grid."""
    import subprocess
    import sys
    from pathlib import Path

    path = write_experiment(methods=[{"label": "DDPG", "algo": "ddpg"}], steps=400)
    out = tmp_path / "out"
    command = [str(Path(sys.executable).with_name("dualsys")), "experiment", "run", str(path)]
    command += ["--out", str(out), "--workers", "2", "--json"]
    process = subprocess.Popen(
        command, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    cells = [out / "tiny" / "DDPG" / "dense" / f"seed-{seed}" for seed in (0, 1)]
    deadline = time.monotonic() + SLOW_MACHINE_TIMEOUT_S / 2
    while not all((cell / "metrics.csv").is_file() for cell in cells):
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=600)
    assert process.returncode == 130, stderr[-2000:]
    assert "run the same command again to resume" in stderr
    for cell in cells:
        assert cell_state(cell) == "partial"  # stopped at a step, with latest.pt
        assert json.loads((cell / "summary.json").read_text())["stopped"] is True
    again = CliRunner().invoke(app, ["experiment", "run", str(path), "--out", str(out), "--json"])
    assert again.exit_code == 0, again.output
    assert sorted(json.loads(again.stdout.strip().splitlines()[-1])["done"]) == [
        "DDPG/dense/seed-0",
        "DDPG/dense/seed-1",
    ]
    for cell in cells:
        episodes = [int(row["episode"]) for row in rows(cell)]
        assert episodes == list(range(1, len(episodes) + 1))
