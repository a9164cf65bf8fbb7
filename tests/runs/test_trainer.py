"""The shared trainer: run-directory files, resume as a continuation, determinism, stop hook, policy load."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from core.config import ConfigError, load_config
from core.runs.policy import PolicyLoadError, load_policy
from core.runs.run_dir import RunDirectoryError, load_checkpoint
from core.runs.trainer import RECORD_KEYS, train
from tests.utils.run_dirs import metrics_rows

TINY = [
    "net.conv_channels=4,4",
    "net.latent_dim=8",
    "net.critic_hidden=8",
    "net.actor_hidden=8",
    "env.max_steps=8",
    "agent.batch_size=8",
    "agent.buffer_size=400",
    "agent.learning_starts=12",
    "run.eval_every=3",
    "run.eval_episodes=2",
    "run.checkpoint_every=2",
    "run.num_threads=1",
]
TIME_KEYS = {"time/wall_s", "charts/sps"}


def tiny(episodes: int, *extra: str):
    return load_config("default", [*TINY, f"run.episodes={episodes}", *extra])


def rows(run_dir) -> list[dict[str, str]]:
    return metrics_rows(run_dir)


def without_time(table: list[dict[str, str]]) -> list[dict[str, str]]:
    return [{k: v for k, v in row.items() if k not in TIME_KEYS} for row in table]


def test_tiny_run_writes_every_run_dir_file_and_loads_as_policy(tmp_path):
    records = []
    summary = train(tiny(4), tmp_path / "run", on_episode=records.append, command="dualsys train --test")
    run = tmp_path / "run"
    for name in (
        "config.yaml",
        "command.txt",
        "metrics.csv",
        "summary.json",
        "learning_curve.png",
        "checkpoints/latest.pt",
        "checkpoints/best.pt",
        "checkpoints/replay.pt",
    ):
        assert (run / name).is_file(), name
    assert (run / "command.txt").read_text() == "dualsys train --test\n"
    saved = json.loads((run / "summary.json").read_text())
    for key in ("run_dir", "episodes", "steps", "final_perf", "auc", "success_rate", "wall_s"):
        assert key in saved
    assert saved["episodes"] == summary["episodes"] == 4
    table = rows(run)
    assert [int(r["episode"]) for r in table] == [1, 2, 3, 4]
    assert set(RECORD_KEYS) <= set(table[0])
    assert [r["episode"] for r in records] == [1, 2, 3, 4]
    returns = [float(r["charts/episodic_return"]) for r in table]
    assert summary["final_perf"] == pytest.approx(np.mean(returns))
    assert int(table[-1]["global_step"]) == summary["steps"] == sum(int(r["charts/length"]) for r in table)
    assert table[2]["eval/success_rate"] != "" and table[1]["eval/success_rate"] == ""
    assert any(r["losses/critic"] != "" for r in table)  # updates happened after learning_starts
    state = load_checkpoint(run / "checkpoints" / "latest.pt")  # weights_only=True
    assert state["counters"]["episode"] == 4
    policy = load_policy(run)
    actions = policy.act(np.zeros((5, 32, 64, 3), dtype=np.uint8))
    assert actions.shape == (5, 1) and np.all(np.abs(actions) <= 1.0)
    with pytest.raises(RunDirectoryError):
        train(tiny(1), run)  # never clobber a run


def test_resume_is_a_continuation_and_same_seed_is_deterministic(tmp_path):
    straight = tmp_path / "straight"
    again = tmp_path / "again"
    split = tmp_path / "split"
    train(tiny(6, "run.final_eval=false"), straight)
    train(tiny(6, "run.final_eval=false"), again)
    assert without_time(rows(straight)) == without_time(rows(again))

    first = train(tiny(3, "run.final_eval=false"), split)
    assert first["episodes"] == 3
    resumed = train(tiny(6, "run.final_eval=false"), split, resume=True)
    assert resumed["episodes"] == 6 and resumed["steps"] == int(rows(straight)[-1]["global_step"])
    assert without_time(rows(split)) == without_time(rows(straight))
    assert (split / "command.txt").read_text().count("\n") == 2
    with pytest.raises(ConfigError, match="net"):
        train(tiny(8, "net.latent_dim=4"), split, resume=True)


def test_should_stop_leaves_a_resumable_checkpoint(tmp_path):
    calls = {"n": 0}

    def stop_after_20_steps() -> bool:
        calls["n"] += 1
        return calls["n"] > 20

    run = tmp_path / "run"
    summary = train(tiny(50), run, should_stop=stop_after_20_steps)
    assert summary["stopped"] is True and summary["episodes"] < 50
    state = load_checkpoint(run / "checkpoints" / "latest.pt")
    assert state["counters"]["global_step"] == summary["steps"] >= 12
    resumed = train(tiny(summary["episodes"] + 2), run, resume=True)
    assert resumed["episodes"] == summary["episodes"] + 2
    assert resumed["steps"] > summary["steps"]
    table = rows(run)
    assert [int(r["episode"]) for r in table] == list(range(1, resumed["episodes"] + 1))


def test_resume_without_a_run_and_bad_policy_paths(tmp_path):
    with pytest.raises(RunDirectoryError):
        train(tiny(1), tmp_path / "empty", resume=True)
    with pytest.raises(PolicyLoadError):
        load_policy(tmp_path / "missing")
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(PolicyLoadError):
        load_policy(tmp_path / "junk.pt")


def test_unknown_algo_is_a_config_error_before_anything_is_written(tmp_path):
    with pytest.raises(ConfigError, match="unknown algo"):
        train(tiny(1, "run.algo=nope"), tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_cacla_sparse_runs(tmp_path):
    summary = train(tiny(3, "run.algo=cacla", "env.reward_mode=sparse"), tmp_path / "run")
    assert summary["ac"] == "cacla" and summary["reward"] == "sparse"
    table = rows(tmp_path / "run")
    assert all(float(r["charts/episodic_return"]) in (-1.0, 0.0, 1.0) for r in table)
    assert torch.load(tmp_path / "run" / "checkpoints" / "best.pt", weights_only=True)["policy"]


def test_policy_round_trip_gives_identical_actions(tmp_path):
    from core.envs.spec import EnvSpec
    from core.runs.methods import make_agent
    from core.runs.run_dir import CHECKPOINT_FORMAT, atomic_torch_save

    config = tiny(1, "env.hand=learned")
    agent = make_agent(config, EnvSpec((32, 64, 3), 2), np.random.default_rng(0))
    obs = np.random.default_rng(1).integers(0, 256, (6, 32, 64, 3), dtype=np.uint8)
    expected = np.stack([agent.act(o, explore=False)[0] for o in obs])
    path = tmp_path / "p.pt"
    atomic_torch_save(
        {
            "format": CHECKPOINT_FORMAT,
            "config": config.to_dict(),
            "obs_shape": [32, 64, 3],
            "policy": agent.policy_state(),
        },
        path,
    )
    policy = load_policy(path)
    assert policy.action_dim == 2
    np.testing.assert_allclose(policy.act(obs), expected, rtol=0, atol=1e-6)
    with pytest.raises(ValueError):
        policy.act(obs.astype(np.float32))
