"""``sb3-sac-pink``: Stable-Baselines3's SAC with ``pink-noise-rl``'s ``PinkNoiseDist`` as the actor's
distribution (the package's example), as an experiment method: the actor's distribution is the package's,
its sequence is the env's step limit, it is the only difference from ``sb3-sac``'s settings, a seed
reproduces a run and a resumed run goes on with the same noise."""

from __future__ import annotations

import json

import pytest

pytest.importorskip(
    "stable_baselines3", reason="Stable-Baselines3 is in the bench extra: pip install -e '.[bench]'"
)

from pink import PinkNoiseDist

import core.experiments.sb3_peer as sb3_peer
from core.config import ConfigError, load_config
from core.experiments import expand_cells, load_experiment, run_cell
from core.experiments.dispatch import runner_for
from core.experiments.sb3_peer import SB3Runner, train_sb3
from tests.utils.run_dirs import metrics_rows

TINY = [
    "env.id=MountainCarContinuous-v0",
    'env.kwargs={"max_episode_steps": 50}',
    "env.success=terminated",
    "run.episodes=none",
    "run.eval_every=0",
    "run.eval_episodes=1",
    "run.final_eval=false",
    "run.checkpoint_every=2",
    "agent.learning_starts=30",
    "agent.batch_size=16",
    "agent.buffer_size=1000",
]


def rows(run_dir) -> list[dict[str, str]]:
    return metrics_rows(run_dir, without_wall_clock=True)


def test_pink_peer_samples_through_pink_noise_dist(tmp_path, monkeypatch):
    built = []
    make_model = sb3_peer.make_model

    def keep(*args, **kwargs):
        built.append(make_model(*args, **kwargs))
        return built[-1]

    monkeypatch.setattr(sb3_peer, "make_model", keep)
    config = load_config("vector", [*TINY, "run.steps=150"])
    summary = train_sb3(config, tmp_path / "pink", algo="sac", pink=True)
    assert summary["algo"] == "sb3-sac-pink" and summary["steps"] == 150
    dist = built[0].actor.action_dist
    assert type(dist) is PinkNoiseDist
    assert dist.gen.time_steps == 50 and dist.action_dim == 1  # seq_len: the env's step limit
    assert dist.gen.idx > 0  # the process was sampled
    record = json.loads((tmp_path / "pink" / "sb3_hyperparams.json").read_text())
    assert record["algo"] == "sb3-sac-pink"
    assert record["action_dist"]["class"] == "pink.sb3.PinkNoiseDist"
    assert record["action_dist"]["seq_len"] == 50
    plain = train_sb3(config, tmp_path / "plain", algo="sac")
    assert type(built[1].actor.action_dist).__name__ == "SquashedDiagGaussianDistribution"
    plain_record = json.loads((tmp_path / "plain" / "sb3_hyperparams.json").read_text())
    assert {k: v for k, v in record.items() if k not in ("algo", "action_dist")} == {
        k: v for k, v in plain_record.items() if k != "algo"
    }  # the same settings but the distribution
    assert plain["algo"] == "sb3-sac" and rows(tmp_path / "plain") != rows(tmp_path / "pink")
    with pytest.raises(ConfigError, match="SAC"):
        train_sb3(config, tmp_path / "td3", algo="td3", pink=True)


def test_pink_peer_is_seeded_and_resumes_with_the_same_noise(tmp_path):
    def run(name: str, steps: int, resume: bool = False):
        return train_sb3(load_config("vector", [*TINY, f"run.steps={steps}"]), tmp_path / name, algo="sac",
                         pink=True, resume=resume)

    run("a", 200)
    run("b", 200)
    assert rows(tmp_path / "a") == rows(tmp_path / "b")
    run("split", 100)  # two episodes: mid-sequence (seq_len = the 50-step limit, the process runs on)
    run("split", 200, resume=True)
    assert rows(tmp_path / "split") == rows(tmp_path / "a")


def test_sb3_sac_pink_is_a_method_of_experiment_files(tmp_path):
    spec = load_experiment({
        "name": "pink", "profile": "vector", "env": "MountainCarContinuous-v0", "seeds": 1, "steps": 100,
        "eval_every": 0, "eval_episodes": 1, "env_kwargs": {"max_episode_steps": 50},
        "overrides": {"env.success": "terminated", "agent.learning_starts": 30, "agent.batch_size": 16,
                      "agent.buffer_size": 1000},
        "methods": [{"label": "SB3-SAC-pink", "algo": "sb3-sac-pink"}],
    })
    runner = runner_for("sb3-sac-pink")
    assert isinstance(runner, SB3Runner) and runner.algo == "sac" and runner.pink
    (cell,) = expand_cells(spec, tmp_path)
    assert cell.config["run"]["algo"] == "sb3-sac-pink"
    assert run_cell(cell)["algo"] == "sb3-sac-pink"
    assert json.loads((cell.run_dir / "summary.json").read_text())["algo"] == "sb3-sac-pink"
