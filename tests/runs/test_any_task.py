"""Every method trains on tasks other than NicoGrasp: vector observations (MountainCarContinuous-v0,
Pendulum-v1 with actions ±2, dm_control through shimmy), images of another shape; the CLI refuses what it
cannot train with one line and no run directory; a vector policy exports to ONNX and is evaluated on its env.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from core.config import load_config
from core.runs.methods import ALGOS, make_agent
from core.runs.trainer import EVAL_SEED, evaluate, make_env, train
from dualsys_cli.main import app
from tests.utils.toy_envs import REFUSED, RecordingPendulum

METHODS = sorted(ALGOS)
TINY_VECTOR = [
    "net.mlp_hidden=16,16",
    "net.latent_dim=8",
    "agent.batch_size=16",
    "agent.learning_starts=50",
    "agent.buffer_size=2000",
    "dual.latent_buffer_size=2000",
    "run.eval_every=0",
    "run.eval_episodes=1",
    "run.episodes=none",
]


def _train(tmp_path, env_id: str, algo: str, steps: int, *extra: str):
    cell = [f"env.id={env_id}", f"run.algo={algo}", f"run.steps={steps}"]
    config = load_config("default", [*TINY_VECTOR, *cell, *extra])
    return train(config, tmp_path / algo)


@pytest.mark.parametrize("algo", METHODS)
def test_every_method_trains_on_mountain_car(tmp_path, algo):
    summary = _train(tmp_path, "MountainCarContinuous-v0", algo, 150, 'env.kwargs={"max_episode_steps": 150}',
                     "env.success=terminated")
    assert summary["steps"] == 150 and summary["reward"] == "task"
    assert summary["env"] == "MountainCarContinuous-v0"
    assert np.isfinite(summary["final_perf"]) and 0.0 <= summary["success_rate"] <= 1.0
    rows = (tmp_path / algo / "metrics.csv").read_text().splitlines()
    assert len(rows) == 2  # header + one episode


@pytest.mark.parametrize("algo", METHODS)
def test_every_method_acts_inside_pendulums_bounds_and_beyond_unit(tmp_path, algo):
    RecordingPendulum.actions.clear()
    _train(tmp_path, "dualsys_test/RecordingPendulum-v0", algo, 200)
    executed = np.concatenate(RecordingPendulum.actions)
    assert executed.size >= 200 + 200  # training steps + the final greedy episode
    assert np.all(np.abs(executed) <= 2.0)
    assert np.abs(executed).max() > 1.2  # [-1, 1] of the agent is mapped onto ±2, not clipped to ±1


def test_the_deployed_policy_answers_in_pendulums_units(tmp_path):
    import torch

    from core.runs.policy import load_policy

    _train(tmp_path, "Pendulum-v1", "ddpg", 200)
    policy = load_policy(tmp_path / "ddpg")
    assert policy.spec.action_low == (-2.0,) and policy.spec.action_high == (2.0,)
    assert float(policy.network.bounds(torch.tensor([[0.75]]))) == pytest.approx(1.5)
    actions = policy.act(np.random.default_rng(0).uniform(-1, 1, (64, 3)).astype(np.float32))
    assert actions.shape == (64, 1) and np.all(np.abs(actions) <= 2.0)


@pytest.mark.parametrize("algo", ["ddpg", "i2a"])
def test_a_dm_control_task_trains(tmp_path, algo):
    pytest.importorskip("shimmy", reason="dm_control tasks need the dmc extra (pip install 'dualsys[dmc]')")
    summary = _train(tmp_path, "dm_control/cartpole-swingup_sparse-v0", algo, 120,
                     'env.kwargs={"max_episode_steps": 120}')
    assert summary["steps"] == 120 and np.isfinite(summary["final_perf"])


@pytest.mark.parametrize("channel_first", [False, True])
@pytest.mark.parametrize("algo", ["ddpg", "i2a"])
def test_images_of_another_shape_train(tmp_path, algo, channel_first):
    summary = _train(
        tmp_path,
        "dualsys_test/ToyImage-v0",
        algo,
        60,
        f'env.kwargs={{"channel_first": {str(channel_first).lower()}}}',
        "net.conv_channels=4,4",
        "agent.learning_starts=20",
        "agent.batch_size=8",
    )
    assert summary["steps"] == 60
    from core.runs.policy import load_policy

    policy = load_policy(tmp_path / algo)
    assert policy.obs_shape == (48, 48, 3)
    assert policy.act(np.zeros((2, 48, 48, 3), np.uint8)).shape == (2, 2)


def _cli(*args: str):
    return CliRunner().invoke(app, list(args))


@pytest.mark.parametrize(("env_id", "message"), REFUSED)
def test_train_refuses_with_one_line_exit_2_and_no_run_directory(tmp_path, env_id, message):
    out = tmp_path / "run"
    result = _cli("train", "--env", env_id, "--steps", "10", "--out", str(out))
    assert result.exit_code == 2, result.output
    assert result.stderr.strip().count("\n") == 0 and message in result.stderr
    assert "Traceback" not in result.output and not out.exists()


@pytest.mark.parametrize(("algo", "encoder"), [("ddpg", "learned"), ("sac", "none"), ("td3", "none")])
def test_a_vector_policy_exports_to_onnx_and_is_evaluated_on_its_env(tmp_path, algo, encoder):
    _train(tmp_path, "Pendulum-v1", algo, 200, f"net.encoder={encoder}")
    onnx_path = tmp_path / "pendulum.onnx"
    exported = _cli("export", "--policy", str(tmp_path / algo), "--out", str(onnx_path), "--json")
    assert exported.exit_code == 0, exported.output
    report = json.loads(exported.stdout.strip().splitlines()[-1])
    assert report["max_abs_diff"] <= 1e-4 and report["metadata"]["input_dtype"] == "float32"
    assert json.loads(report["metadata"]["action_high"]) == [2.0]
    from core.deploy import OnnxPolicy
    from core.runs.policy import load_policy

    obs = np.random.default_rng(0).uniform(-1, 1, (16, 3)).astype(np.float32)
    expected = load_policy(tmp_path / algo).act(obs)  # SAC: the deterministic action tanh(mean)
    np.testing.assert_allclose(OnnxPolicy(onnx_path).act(obs), expected, atol=1e-5)
    for source in (str(tmp_path / algo), str(onnx_path)):
        evaluated = _cli("eval", "--policy", source, "--trials", "2", "--json")
        assert evaluated.exit_code == 0, evaluated.output
        result = json.loads(evaluated.stdout.strip().splitlines()[-1])
        assert result["trials"] == 2 and len(result["per_trial"]) == 2
        assert all(episode["steps"] == 200 for episode in result["per_trial"])  # Pendulum's own time limit
        assert result["mean_return"] < 0


@pytest.mark.parametrize("algo", ["td3", "im2c"])
def test_greedy_evaluation_logs_the_critics_start_value_beside_the_discounted_return(algo):
    """eval/start_value is the mean over the evaluation episodes of the critic's value of each start state at
    the greedy action; eval/discounted_return the mean of Σ_t γ^t r_t the greedy episode earned; without γ
    neither is logged; the greedy episodes themselves are unchanged."""
    gamma = 0.9
    config = load_config("default", [*TINY_VECTOR, "env.id=Pendulum-v1", f"run.algo={algo}", "agent.ac=td3",
                                     f"agent.gamma={gamma}"])
    adapted = make_env(config, evaluation=True)
    env = adapted.env
    agent = make_agent(config, adapted.spec, np.random.default_rng(0))
    result = evaluate(agent, env, episodes=2, gamma=gamma)
    values, discounted, returns = [], [], []
    for k in range(2):
        obs, _ = env.reset(seed=EVAL_SEED + k)
        values.append(agent.start_value(obs))
        rewards = []
        while True:
            action, _ = agent.act(obs, explore=False)
            obs, reward, terminated, truncated, _ = env.step(action)
            rewards.append(float(reward))
            if terminated or truncated:
                break
        discounted.append(sum(gamma**t * r for t, r in enumerate(rewards)))
        returns.append(sum(rewards))
    assert result["eval/start_value"] == pytest.approx(np.mean(values))
    assert result["eval/discounted_return"] == pytest.approx(np.mean(discounted))
    assert result["eval/return"] == pytest.approx(np.mean(returns))
    assert len(set(values)) == 2  # one value per start state, not one for all
    plain = evaluate(agent, env, episodes=2)
    assert "eval/start_value" not in plain and "eval/discounted_return" not in plain
    assert plain["eval/return"] == result["eval/return"]
