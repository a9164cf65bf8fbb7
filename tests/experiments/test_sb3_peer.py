"""Stable-Baselines3 SAC/TD3/DDPG as experiment methods (core/experiments/sb3_peer.py, sb3_settings.py): the
run directory and its keys match the trainer's, stop + resume continues the same episodes (on NicoGrasp's
images, and on a vector task with the zoo's 32-step rollouts), a seed reproduces a run, the features extractor
is our encoder, vector tasks get MlpPolicy, the dualsys setting is exactly NON_DEFAULTS, and
``dualsys experiment run`` trains ``sb3-sac``/``sb3-td3``/``sb3-ddpg`` on NicoGrasp, MountainCarContinuous-v0
(the zoo's hyperparameters) and Pendulum-v1."""

from __future__ import annotations

import json
import math
import sys

import pytest
import yaml
from typer.testing import CliRunner

pytest.importorskip(
    "stable_baselines3", reason="Stable-Baselines3 is in the bench extra: pip install -e '.[bench]'"
)

import torch
from gymnasium import spaces

from core.config import Config, NetConfig, load_config
from core.experiments import cell_state, expand_cells, load_experiment, run_cell, run_experiment
from core.experiments.dispatch import runner_for
from core.experiments.report import build_report
from core.experiments.sb3_peer import SB3Runner, train_sb3
from core.experiments.sb3_settings import (
    NON_DEFAULTS,
    DualsysEncoderExtractor,
    missing_sb3_message,
    require_sb3,
    sb3_settings,
)
from core.experiments.spec import ExperimentError
from core.modelfree.networks import Encoder
from core.runs.run_dir import load_checkpoint
from core.runs.trainer import RECORD_KEYS, train
from dualsys_cli.main import app
from tests.experiments.conftest import tiny_experiment_data
from tests.utils.run_dirs import metrics_rows

TINY = [
    "env.level=hard",
    "env.reward_mode=sparse",
    "env.max_steps=10",
    "run.steps=60",
    "run.episodes=none",
    "run.eval_every=8",
    "run.eval_episodes=2",
    "run.checkpoint_every=4",
    "agent.learning_starts=20",
    "agent.buffer_size=500",
    "agent.batch_size=8",
]


def rows(run_dir) -> list[dict[str, str]]:
    return metrics_rows(run_dir)


def returns(run_dir) -> list[tuple[int, int, float]]:
    return [
        (int(r["episode"]), int(r["global_step"]), float(r["charts/episodic_return"])) for r in rows(run_dir)
    ]


def test_extractor_is_our_encoder_on_channels_first_images_scaled_once():
    space = spaces.Box(0, 255, (3, 32, 64), dtype="uint8")  # what VecTransposeImage hands SB3's policy
    extractor = DualsysEncoderExtractor(space, arch="strided", conv_channels=[16, 32, 32], latent_dim=32)
    ours = Encoder(NetConfig())
    assert extractor.features_dim == 32
    assert [(n, p.shape) for n, p in extractor.encoder.named_parameters()] == [
        (n, p.shape) for n, p in ours.named_parameters()
    ]
    assert str(extractor.encoder) == str(ours)
    images = torch.randint(0, 256, (5, 32, 64, 3), dtype=torch.uint8)
    ours.load_state_dict(extractor.encoder.state_dict())
    # SB3 feeds float [N, C, H, W] already divided by 255; our encoder expects exactly that
    chw = images.permute(0, 3, 1, 2).float() / 255.0
    features = extractor(chw)
    assert features.shape == (5, 32)
    assert torch.allclose(features, ours(chw))
    with pytest.raises(ValueError, match="channels-first"):
        DualsysEncoderExtractor(spaces.Box(0, 255, (32, 64, 3), dtype="uint8"))


def test_sac_policy_sees_uint8_observations_through_the_extractor_once_scaled(tmp_path):
    from stable_baselines3 import SAC
    from stable_baselines3.common.vec_env import DummyVecEnv

    from core.experiments.sb3_settings import extractor_kwargs
    from core.runs.trainer import make_env

    config = load_config("default", TINY)
    env = make_env(config).env
    model = SAC(
        "CnnPolicy",
        DummyVecEnv([lambda: env]),
        policy_kwargs={
            "features_extractor_class": DualsysEncoderExtractor,
            "features_extractor_kwargs": extractor_kwargs(config.net),
        },
        buffer_size=10,
        seed=0,
        device="cpu",
    )
    try:
        assert model.observation_space.shape == (3, 32, 64)  # transposed by SB3
        for extractor in (model.actor.features_extractor, model.critic.features_extractor):
            assert isinstance(extractor, DualsysEncoderExtractor)
        obs, _ = env.reset(seed=0)
        tensor, _ = model.policy.obs_to_tensor(obs)  # HWC uint8 → CHW, as predict() does
        features = model.actor.extract_features(tensor, model.actor.features_extractor)
        expected = model.actor.features_extractor.encoder(
            torch.as_tensor(obs).permute(2, 0, 1)[None].float() / 255.0
        )
        assert torch.allclose(features, expected)
        action, _ = model.predict(obs, deterministic=True)
        assert action.shape == env.action_space.shape
    finally:
        env.close()


def test_tiny_sac_run_writes_the_trainers_files_and_keys(tmp_path):
    config = load_config("default", TINY)
    episodes: list[dict] = []
    summary = train_sb3(config, tmp_path / "sac", algo="sac", on_episode=episodes.append, command="test")
    ddpg = train(load_config("default", [*TINY, "run.algo=ddpg"]), tmp_path / "ddpg", command="test")
    run = tmp_path / "sac"
    for name in ("config.yaml", "command.txt", "metrics.csv", "summary.json", "learning_curve.png"):
        assert (run / name).is_file(), name
    for name in ("latest.pt", "best.zip"):
        assert (run / "checkpoints" / name).is_file(), name
    assert set(summary) == set(ddpg)  # the same summary keys as the trainer's
    assert json.loads((run / "summary.json").read_text())["algo"] == "sb3-sac"
    assert summary["stopped"] is False and 60 <= summary["steps"] < 70  # the budget, to the episode
    assert summary["success_rate"] is not None and summary["eval_episodes"] == 2
    header = list(rows(run)[0])
    assert header[: len(RECORD_KEYS)] == list(RECORD_KEYS)
    data = rows(run)
    assert (
        [int(r["episode"]) for r in data] == list(range(1, len(data) + 1)) == [e["episode"] for e in episodes]
    )
    assert int(data[-1]["global_step"]) == summary["steps"]
    assert sum(int(r["charts/length"]) for r in data) == summary["steps"]
    assert all(r["eval/success_rate"] != "" for r in data if int(r["episode"]) % 8 == 0)
    assert any(r["losses/critic"] != "" for r in data)  # SAC updated after learning_starts
    from core.runs.metrics import area_under_curve, final_performance

    episode_returns = [float(r["charts/episodic_return"]) for r in data]
    assert summary["auc"] == pytest.approx(area_under_curve(episode_returns))
    assert summary["final_perf"] == pytest.approx(final_performance(episode_returns))
    stored = yaml.safe_load((run / "config.yaml").read_text())
    assert stored["run"]["algo"] == "sb3-sac" and stored["env"]["level"] == "hard"
    latest = load_checkpoint(run / "checkpoints" / "latest.pt")
    assert latest["counters"]["global_step"] == summary["steps"]
    sb3_files = sorted(p.name for p in (run / "checkpoints").glob("sb3-*"))
    assert sb3_files == sorted([latest["sb3"]["model"], latest["sb3"]["replay"]])  # older pairs removed
    with pytest.raises(ValueError, match="already holds a run"):
        train_sb3(config, run, algo="sac")


def test_same_seed_same_episodes_and_stop_resume_continues_them(tmp_path):
    config = load_config("default", TINY)
    train_sb3(config, tmp_path / "a", algo="sac", command="test")
    train_sb3(config, tmp_path / "b", algo="sac", command="test")
    reference = returns(tmp_path / "a")
    assert reference == returns(tmp_path / "b")  # SB3 on CPU, single thread: bit for bit

    stop_at = {"episode": 7}
    seen: list[int] = []

    def on_episode(record):
        seen.append(record["episode"])

    summary = train_sb3(
        config,
        tmp_path / "c",
        algo="sac",
        on_episode=on_episode,
        should_stop=lambda: bool(seen) and seen[-1] >= stop_at["episode"],
        command="test",
    )
    assert summary["stopped"] is True and summary["episodes"] == 7
    assert cell_state(tmp_path / "c") == "partial"
    summary = train_sb3(config, tmp_path / "c", algo="sac", resume=True, command="test")
    assert summary["stopped"] is False
    resumed = returns(tmp_path / "c")
    assert [e for e, _, _ in resumed] == list(range(1, len(resumed) + 1))  # no duplicate, none missing
    assert resumed == reference  # the resumed run is the uninterrupted one
    values = [(r["charts/start_value"], r["charts/discounted_return"]) for r in rows(tmp_path / "c")]
    assert values == [(r["charts/start_value"], r["charts/discounted_return"]) for r in rows(tmp_path / "a")]
    assert (tmp_path / "c" / "command.txt").read_text().count("test") == 2


def test_td3_runs_and_resume_refuses_another_algorithm(tmp_path):
    config = load_config("default", [*TINY, "run.steps=30", "agent.gamma=1.0", "run.eval_every=2"])
    summary = train_sb3(config, tmp_path / "td3", algo="td3", command="test")
    assert summary["algo"] == "sb3-td3" and summary["steps"] >= 30
    # The overestimation pair, as our trainer logs it: with γ = 1 the discounted return is the return; the
    # start value is the critic's, finite, and moves as the critic learns.
    data = rows(tmp_path / "td3")
    for row in data:
        assert float(row["charts/discounted_return"]) == pytest.approx(float(row["charts/episodic_return"]))
    start_values = [float(row["charts/start_value"]) for row in data]
    assert all(math.isfinite(v) for v in start_values) and len(set(start_values)) > 1
    # ... and at the greedy evaluations: the critic's value of the evaluation starts beside what the greedy
    # episodes earned (γ = 1: their return).
    evaluations = [row for row in data if row["eval/return"]]
    assert evaluations
    for row in evaluations:
        assert float(row["eval/discounted_return"]) == pytest.approx(float(row["eval/return"]))
        assert math.isfinite(float(row["eval/start_value"]))
    with pytest.raises(ValueError, match="sb3-td3"):
        train_sb3(config, tmp_path / "td3", algo="sac", resume=True)


def test_experiment_runner_dispatches_sb3_methods(tmp_path):
    data = tiny_experiment_data(
        level="hard",
        rewards=["sparse"],
        seeds=1,
        steps=30,
        methods=[{"label": "DDPG", "algo": "ddpg"}, {"label": "SAC", "algo": "sb3-sac"}],
    )
    spec = load_experiment(data)
    for name in ("sb3-sac", "sb3-td3", "sb3-ddpg"):
        assert isinstance(runner_for(name), SB3Runner)
    cells = expand_cells(spec, tmp_path)
    sac = next(cell for cell in cells if cell.algo == "sb3-sac")
    assert sac.config["run"]["algo"] == "sb3-sac" and sac.config["run"]["num_threads"] == 1
    assert sac.config["agent"]["batch_size"] == 8  # the experiment's overrides reach SB3 cells too
    result = run_experiment(spec, tmp_path, workers=1)
    assert result.complete, result.to_dict()
    assert cell_state(sac.run_dir) == "done"
    assert run_cell(sac)["algo"] == "sb3-sac"  # a done cell is skipped: its stored summary
    report = build_report(tmp_path / "tiny", reps=50)
    assert set(report["methods"]) == {"DDPG", "SAC"}
    assert report["methods"]["SAC"]["sparse"]["auc"]["n"] == 1
    with pytest.raises(ExperimentError, match="no actor-update rule"):
        load_experiment({**data, "methods": [{"label": "SAC", "algo": "sb3-sac", "ac": "ddpg"}]})


def test_missing_sb3_is_a_one_line_error(monkeypatch, tmp_path, write_experiment):
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # import fails as if not installed
    with pytest.raises(ExperimentError) as error:
        require_sb3("sb3-sac")
    assert str(error.value) == missing_sb3_message("sb3-sac")
    assert str(error.value) == "sb3-sac needs Stable-Baselines3: pip install 'dualsys[bench]'"
    data = tiny_experiment_data(methods=[{"label": "TD3", "algo": "sb3-td3"}])
    with pytest.raises(ExperimentError, match=r"^sb3-td3 needs Stable-Baselines3"):
        load_experiment(data)
    path = write_experiment(methods=[{"label": "SAC", "algo": "sb3-sac"}])
    result = CliRunner().invoke(app, ["experiment", "run", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.output.strip() == "error: sb3-sac needs Stable-Baselines3: pip install 'dualsys[bench]'"
    assert not (tmp_path / "out").exists()


# -- vector tasks ---------------------------------------------------------------------------------

MOUNTAIN_CAR = "MountainCarContinuous-v0"


def vector_grid(path, env: str, methods: list[dict], steps: int = 300, **changes) -> None:
    """A tiny experiment file on ``env``: 100-step episodes, one seed, one final 1-episode evaluation."""
    data = {
        "name": "vector",
        "env": env,
        "env_kwargs": {"max_episode_steps": 100},
        "seeds": 1,
        "steps": steps,
        "eval_every": 0,
        "eval_episodes": 1,
        "overrides": {"env.success": "terminated", "run.checkpoint_every": 2},
        "methods": methods,
        **changes,
    }
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def run_grid(path, out) -> dict:
    result = CliRunner().invoke(
        app, ["experiment", "run", str(path), "--out", str(out), "--workers", "1", "--json"]
    )
    assert result.exit_code == 0, result.output
    outcome = json.loads(result.stdout.strip().splitlines()[-1])
    assert outcome["complete"], outcome
    return outcome


@pytest.mark.timeout(1800)  # worker processes on a loaded 2-core machine (see test_experiment_run.py)
def test_experiment_run_trains_the_zoo_peers_on_mountaincar(tmp_path):
    from tests.experiments.test_sb3_zoo import package_entry

    path = tmp_path / "mountaincar.yaml"
    zoo = {"agent.sb3_hyperparams": "zoo"}
    methods = [
        {"label": f"SB3-{algo.upper()}-zoo", "algo": f"sb3-{algo}", "overrides": zoo}
        for algo in ("ddpg", "sac", "td3")
    ]
    vector_grid(path, MOUNTAIN_CAR, methods)
    outcome = run_grid(path, tmp_path / "out")
    assert sorted(outcome["done"]) == [f"SB3-{a}-zoo/task/seed-0" for a in ("DDPG", "SAC", "TD3")]
    for algo in ("ddpg", "sac", "td3"):
        cell = tmp_path / "out" / "vector" / f"SB3-{algo.upper()}-zoo" / "task" / "seed-0"
        summary = json.loads((cell / "summary.json").read_text())
        assert summary["algo"] == f"sb3-{algo}" and summary["env"] == MOUNTAIN_CAR
        assert 300 <= summary["steps"] < 400 and summary["episodes"] >= 3 and not summary["stopped"]
        assert yaml.safe_load((cell / "config.yaml").read_text())["agent"]["sb3_hyperparams"] == "zoo"
        record = json.loads((cell / "sb3_hyperparams.json").read_text())
        entry = package_entry(algo, MOUNTAIN_CAR)
        assert record["setting"] == "zoo" and record["zoo_entry"] == entry
        assert record["zoo_unused"] == {"n_timesteps": entry["n_timesteps"]}
        assert record["used"]["learning_rate"] == pytest.approx(entry["learning_rate"])
        assert any(r["losses/critic"] != "" for r in rows(cell))  # it trained
    noise = json.loads((tmp_path / "out/vector/SB3-DDPG-zoo/task/seed-0/sb3_hyperparams.json").read_text())
    assert noise["used"]["action_noise"]["class"] == "OrnsteinUhlenbeckActionNoise"
    assert noise["used"]["action_noise"]["sigma"] == [0.5]
    sac = json.loads((tmp_path / "out/vector/SB3-SAC-zoo/task/seed-0/sb3_hyperparams.json").read_text())
    assert sac["used"]["use_sde"] is True and sac["used"]["train_freq"] == [32, "step"]
    report = build_report(tmp_path / "out" / "vector", reps=50)
    assert set(report["methods"]) == {"SB3-DDPG-zoo", "SB3-SAC-zoo", "SB3-TD3-zoo"}


@pytest.mark.timeout(1800)
def test_experiment_run_trains_the_sb3_peers_on_pendulum_with_mlp_policies(tmp_path):
    path = tmp_path / "pendulum.yaml"
    methods = [{"label": f"SB3-{algo.upper()}", "algo": f"sb3-{algo}"} for algo in ("ddpg", "sac", "td3")]
    methods.append({"label": "SB3-SAC-zoo", "algo": "sb3-sac", "overrides": {"agent.sb3_hyperparams": "zoo"}})
    vector_grid(
        path,
        "Pendulum-v1",
        methods,
        overrides={"agent.learning_starts": 100, "agent.batch_size": 32, "agent.buffer_size": 1000},
    )
    outcome = run_grid(path, tmp_path / "out")
    assert len(outcome["done"]) == 4
    for method in methods:
        cell = tmp_path / "out" / "vector" / method["label"] / "task" / "seed-0"
        summary = json.loads((cell / "summary.json").read_text())
        assert summary["steps"] == 300 and summary["episodes"] == 3 and summary["env"] == "Pendulum-v1"
        record = json.loads((cell / "sb3_hyperparams.json").read_text())
        assert record["policy"] == "MlpPolicy"
        if method["label"].endswith("zoo"):
            assert record["setting"] == "zoo" and record["used"]["batch_size"] == 256  # the zoo's (SB3's)
        else:
            assert record["setting"] == "dualsys" and record["used"]["batch_size"] == 32  # ours
            assert record["used"]["learning_starts"] == 100 and record["non_defaults"] == NON_DEFAULTS
        assert any(r["losses/critic"] != "" for r in rows(cell))


@pytest.mark.parametrize("algo", ["sac", "td3", "ddpg"])
def test_the_dualsys_setting_differs_from_sb3_defaults_exactly_by_non_defaults(algo):
    from stable_baselines3.common.noise import NormalActionNoise

    from core.runs.trainer import make_env

    for env_id, policy in ((MOUNTAIN_CAR, "MlpPolicy"), ("dualsys/NicoGrasp-v0", "CnnPolicy")):
        config = load_config("default", [f"env.id={env_id}"])
        adapted = make_env(config)
        adapted.env.close()
        settings = sb3_settings(config, algo, adapted.spec)
        assert settings.name == "dualsys" and settings.policy == policy
        given = set(settings.kwargs)
        if policy == "CnnPolicy":
            assert settings.kwargs["policy_kwargs"]["features_extractor_class"] is DualsysEncoderExtractor
            given = given - {"policy_kwargs"} | {"policy_kwargs.features_extractor_class (images)"}
        if algo in ("td3", "ddpg"):
            assert isinstance(settings.kwargs["action_noise"], NormalActionNoise)
            given = given - {"action_noise"} | {"action_noise (td3, ddpg)"}
        # every argument we give is a documented non-default (seed and device are given by make_model)
        assert given <= set(NON_DEFAULTS) and set(NON_DEFAULTS) - given <= {
            "seed",
            "device",
            "policy_kwargs.features_extractor_class (images)",
            "action_noise (td3, ddpg)",
        }


def test_a_vector_zoo_cell_stopped_inside_a_rollout_resumes_to_the_uninterrupted_episodes(tmp_path):
    """SAC's zoo entry for MountainCarContinuous-v0 updates every 32 steps with gSDE noise: 50-step episodes
    end inside rollouts, where checkpoints, stops and resumes must not move an update or a noise sample."""
    from stable_baselines3 import SAC

    data = {
        "name": "resume",
        "env": MOUNTAIN_CAR,
        "env_kwargs": {"max_episode_steps": 50},
        "seeds": 1,
        "steps": 250,
        "eval_every": 2,
        "eval_episodes": 1,
        "overrides": {"agent.sb3_hyperparams": "zoo", "env.success": "terminated"},
        "methods": [{"label": "SB3-SAC-zoo", "algo": "sb3-sac"}],
    }
    (cell,) = expand_cells(load_experiment(data), tmp_path / "stopped")

    def with_checkpoints_every(episodes: int) -> Config:
        return Config.from_dict({**cell.config, "run": {**cell.config["run"], "checkpoint_every": episodes}})

    def episodes(run_dir) -> list[tuple]:
        pairs = zip(returns(run_dir), rows(run_dir), strict=True)
        return [(*episode, row["losses/critic"]) for episode, row in pairs]

    train_sb3(with_checkpoints_every(1000), tmp_path / "straight", algo="sac", command="test")
    reference = episodes(tmp_path / "straight")
    assert len(reference) == 5 and all(int(r["charts/length"]) == 50 for r in rows(tmp_path / "straight"))
    assert any(r["losses/critic"] != "" for r in rows(tmp_path / "straight"))
    # a checkpoint after every episode leaves learn() inside the rollout and goes on: the same episodes
    train_sb3(with_checkpoints_every(1), tmp_path / "every", algo="sac", command="test")
    assert episodes(tmp_path / "every") == reference
    # the cell, stopped after episode 3 (step 150: inside the fifth 32-step rollout), then run again
    seen: list[int] = []
    summary = run_cell(
        cell, on_episode=lambda record: seen.append(record["episode"]), should_stop=lambda: len(seen) >= 3
    )
    assert summary["stopped"] is True and summary["episodes"] == 3
    assert cell_state(cell.run_dir) == "partial"
    latest = load_checkpoint(cell.run_dir / "checkpoints" / "latest.pt")
    assert latest["sb3"]["rollout"] == {"steps": 150 % 32, "episodes": 1}
    assert set(latest["sb3"]["sde"]) == {"exploration_mat", "exploration_matrices"}
    summary = run_cell(cell)
    assert summary["stopped"] is False and cell_state(cell.run_dir) == "done"
    assert episodes(cell.run_dir) == reference
    # the zoo's schedules see our budget: SB3's progress_remaining = 1 - num_timesteps / run.steps
    latest = load_checkpoint(cell.run_dir / "checkpoints" / "latest.pt")
    model = SAC.load(cell.run_dir / "checkpoints" / latest["sb3"]["model"], device="cpu")
    assert model._current_progress_remaining == pytest.approx(1 - 250 / cell.config["run"]["steps"])
