"""Experiment files: validation (one line naming the key, exit 2, nothing written), the shipped grids,
cell expansion and the method → runner dispatch."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from core.experiments import ExperimentError, expand_cells, load_experiment
from core.experiments.dispatch import CELL_RUNNERS, register_cell_runner, runner_for
from core.experiments.runners import TRAINER_RUNNER
from dualsys_cli.main import app
from tests.experiments.conftest import tiny_experiment_data

SHIPPED = Path(__file__).resolve().parents[2] / "experiments"


def _bad(**changes):
    return tiny_experiment_data(**changes)


BAD_FILES = {
    "unknown algo": (
        _bad(methods=[{"label": "X", "algo": "nonsense"}]),
        "methods[0].algo: unknown algo 'nonsense'",
    ),
    "unknown key": (_bad(budget=100), "unknown key 'budget'"),
    "unknown method key": (
        _bad(methods=[{"label": "X", "algo": "ddpg", "actor": "ddpg"}]),
        "unknown key 'methods[0].actor'",
    ),
    "unknown config key": (_bad(overrides={"agent.nonsense": 1}), "unknown config key 'agent.nonsense'"),
    "zero seeds": (_bad(seeds=0), "seeds: an experiment needs at least one seed"),
    "empty seed list": (_bad(seeds=[]), "seeds: an experiment needs at least one seed"),
    "missing budget": (
        {k: v for k, v in tiny_experiment_data().items() if k != "steps"},
        "missing key 'steps'",
    ),
    "reserved key": (_bad(overrides={"run.seed": 3}), "run.seed is set by the experiment"),
    "bad level": (_bad(level="easy"), "bad value for level: 'easy'"),
    "bad reward": (_bad(rewards=["dense", "shaped"]), "bad value for rewards: 'shaped'"),
    "duplicate label": (
        _bad(methods=[{"label": "A", "algo": "ddpg"}, {"label": "A", "algo": "cacla"}]),
        "methods[1].label: 'A' is used twice",
    ),
    "ac against algo": (
        _bad(methods=[{"label": "A", "algo": "ddpg", "ac": "cacla"}]),
        "ddpg always uses the ddpg actor update",
    ),
    "bad override value": (_bad(overrides={"agent.batch_size": "many"}), "agent.batch_size"),
    "unknown baseline": (_bad(baseline="PPO"), "baseline: 'PPO' is not a method label"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_file_is_one_line_exit_2_and_writes_nothing(tmp_path, case):
    data, message = BAD_FILES[case]
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["experiment", "run", str(path), "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip().count("\n") == 0, result.stderr
    assert message in result.stderr
    assert "Traceback" not in result.output
    assert not out.exists()


def test_unreadable_and_missing_files(tmp_path):
    missing = CliRunner().invoke(app, ["experiment", "run", str(tmp_path / "none.yaml")])
    assert missing.exit_code == 2 and "experiment file not found" in missing.stderr
    broken = tmp_path / "broken.yaml"
    broken.write_text("name: [unclosed\n")
    result = CliRunner().invoke(app, ["experiment", "run", str(broken)])
    assert result.exit_code == 2 and "cannot parse" in result.stderr


@pytest.mark.parametrize("name", ["smoke", "table1", "fig10", "fig11"])
def test_shipped_grids_load(name):
    spec = load_experiment(SHIPPED / f"{name}.yaml")
    assert spec.name == name
    if name != "smoke":
        assert spec.rewards == ("dense", "sparse")
        assert len(spec.seeds) == 5  # the paper averages 5 seeds
        assert len({method.label for method in spec.methods}) in (3, 4)


def test_shipped_mountaincar_grid_and_a_task_without_levels_round_trips(tmp_path):
    if importlib.util.find_spec("rl_zoo3") is None:  # found, never imported: importing it patches gymnasium
        pytest.skip("RL Baselines3 Zoo is in the bench extra (the SB3 zoo peers)")
    spec = load_experiment(SHIPPED / "mountaincar.yaml")
    assert spec.env == "MountainCarContinuous-v0" and spec.rewards == ("task",) and spec.steps == 50_000
    assert spec.seeds == (1, 2, 3, 4, 5)
    assert [(m.label, m.algo) for m in spec.methods] == [
        ("DDPG", "ddpg"),
        ("DDPG+IM2C", "im2c"),
        ("DDPG+I2A", "i2a"),
        ("DDPG+RND", "rnd"),
        ("SB3-DDPG-zoo", "sb3-ddpg"),
        ("SB3-SAC-zoo", "sb3-sac"),
    ]
    cells = expand_cells(spec, tmp_path)
    assert {c.config["agent"]["sb3_hyperparams"] for c in cells if c.algo.startswith("sb3-")} == {"zoo"}
    assert {c.config["env"]["success"] for c in cells} == {"terminated"}
    stored = spec.to_dict()  # what experiment.yaml holds, and what a report reads back
    assert "level" not in stored and load_experiment(stored) == spec


def test_shipped_grids_are_the_papers(tmp_path):
    algos = {
        name: {(m.label, m.algo, m.ac) for m in load_experiment(SHIPPED / f"{name}.yaml").methods}
        for name in ("table1", "fig10", "fig11")
    }
    assert {a for _, a, _ in algos["table1"]} == {"ddpg", "cacla", "im2c"}
    assert ("CACLA+IM2C", "im2c", "cacla") in algos["table1"]
    assert {a for _, a, _ in algos["fig10"]} == {"im2c", "cmc", "mve"}
    assert {a for _, a, _ in algos["fig11"]} == {"i2a", "im2c", "la-imagination"}


def test_cells_are_run_directories_with_the_cell_keys(tmp_path):
    spec = load_experiment(yaml.safe_dump(tiny_experiment_data(rewards=["dense", "sparse"], seeds=[3, 7])))
    cells = expand_cells(spec, tmp_path)
    assert len(cells) == 2 * 2 * 2
    im2c = next(c for c in cells if c.label == "DDPG+IM2C" and c.reward == "sparse" and c.seed == 7)
    assert im2c.run_dir == tmp_path / "tiny" / "DDPG+IM2C" / "sparse" / "seed-7"
    config = im2c.config
    assert config["run"]["algo"] == "im2c" and config["agent"]["ac"] == "ddpg"
    assert config["run"]["seed"] == 7 and config["run"]["steps"] == 100 and config["run"]["episodes"] is None
    assert config["run"]["max_wall_s"] is None and config["run"]["num_threads"] == 1
    assert config["env"]["reward_mode"] == "sparse" and config["env"]["level"] == "released"
    assert config["run"]["eval_every"] == 10 and config["run"]["eval_episodes"] == 2
    assert config["net"]["conv_channels"] == [4, 4] and config["run"]["checkpoint_every_s"] == 60.0
    assert not tmp_path.joinpath("tiny").exists()  # expanding writes nothing


def test_level_is_passed_as_env_level(tmp_path):
    spec = load_experiment(yaml.safe_dump(tiny_experiment_data(level="paper")))
    config = expand_cells(spec, tmp_path)[0].config
    assert config["env"]["level"] == "paper" and config["env"]["hand"] == "learned"


def test_a_new_algo_family_plugs_in_through_the_runner_registry():
    class ProbeRunner:
        def resolve(self, spec, method, reward, seed):
            return {"run": {"algo": method.algo, "seed": seed, "steps": spec.steps}, "env": {}}

        def normalise(self, stored):
            return dict(stored)

        def train(self, config, run_dir, **kwargs):  # pragma: no cover - not run here
            raise NotImplementedError

    assert runner_for("ddpg") is TRAINER_RUNNER
    with pytest.raises(ExperimentError, match="unknown algo 'probe-sac'"):
        runner_for("probe-sac")
    register_cell_runner("probe-sac", ProbeRunner())
    try:
        data = tiny_experiment_data(methods=[{"label": "P", "algo": "probe-sac"}])
        spec = load_experiment(yaml.safe_dump(data))
        assert expand_cells(spec, "out")[0].config["run"] == {"algo": "probe-sac", "seed": 0, "steps": 100}
    finally:
        CELL_RUNNERS.pop("probe-sac")


@pytest.mark.timeout(1800)  # spawns workers twice; minutes on a loaded shared machine
def test_bench_experiment_contract(tmp_path, write_experiment):
    """`dualsys bench experiment --json` on a two-cell grid: both timings and their ratio."""
    import json

    path = write_experiment(methods=[{"label": "DDPG", "algo": "ddpg"}], steps=30)
    result = CliRunner().invoke(app, ["bench", "experiment", "--file", str(path), "--json"])
    assert result.exit_code == 0, result.output
    figures = json.loads(result.stdout.strip().splitlines()[-1])
    assert figures["cells"] == 2 and figures["workers_1_s"] > 0 and figures["workers_2_s"] > 0
    assert figures["speedup"] == pytest.approx(figures["workers_1_s"] / figures["workers_2_s"], abs=0.01)


@pytest.mark.parametrize("path", sorted(SHIPPED.glob("*.yaml")), ids=lambda path: path.stem)
def test_every_shipped_experiment_file_loads_under_its_own_name(path):
    """`dualsys experiment run NAME` finds experiments/NAME.yaml and writes dualsys-experiments/NAME/: the two
    names must agree, or a report would be looked for in the wrong folder."""
    spec = load_experiment(path)
    assert spec.name == path.stem
    assert spec.methods and spec.seeds and spec.steps > 0
