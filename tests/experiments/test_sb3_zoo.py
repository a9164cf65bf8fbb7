"""RL Baselines3 Zoo's hyperparameters as SB3 objects (core/experiments/sb3_zoo.py, sb3_settings.py): the
MountainCarContinuous-v0 entries of sac, ddpg and td3 become the models the zoo would build (expectations
read from the installed package's yml, so the test follows the data), policy_kwargs are parsed as literals
only, lin_ schedules run to zero, the zoo's package is never imported, and an entry that is missing or
cannot be translated is one line (exit 2 from the CLI, nothing written)."""

from __future__ import annotations

import ast
import importlib.metadata
import importlib.util
import sys

import pytest
import yaml
from typer.testing import CliRunner

pytest.importorskip(
    "stable_baselines3", reason="Stable-Baselines3 is in the bench extra: pip install -e '.[bench]'"
)
if importlib.util.find_spec("rl_zoo3") is None:  # pragma: no cover - the bench extra installs it
    pytest.skip("rl-zoo3 is in the bench extra: pip install -e '.[bench]'", allow_module_level=True)

import gymnasium
from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise
from stable_baselines3.common.vec_env import DummyVecEnv

from core.config import load_config
from core.experiments import load_experiment
from core.experiments.sb3_settings import make_model, sb3_settings
from core.experiments.sb3_zoo import parse_policy_kwargs, zoo_entry, zoo_settings, zoo_table
from core.experiments.spec import ExperimentError
from core.runs.trainer import make_env
from dualsys_cli.main import app

MOUNTAIN_CAR = "MountainCarContinuous-v0"


def package_entry(algo: str, env_id: str) -> dict:
    """The entry as the installed rl-zoo3 ships it (found through its distribution's file list)."""
    path = importlib.metadata.distribution("rl-zoo3").locate_file(f"rl_zoo3/hyperparams/{algo}.yml")
    return yaml.safe_load(path.read_text())[env_id]


def keyword_literals(text: str) -> dict:
    """``dict(a=1, b=[2])`` → ``{"a": 1, "b": [2]}``, each keyword's value by ``ast.literal_eval``."""
    call = ast.parse(text, mode="eval").body
    assert isinstance(call, ast.Call)
    return {keyword.arg: ast.literal_eval(keyword.value) for keyword in call.keywords}


def zoo_model(algo: str, env_id: str = MOUNTAIN_CAR):
    config = load_config("default", [f"env.id={env_id}", "agent.sb3_hyperparams=zoo", "run.steps=1000"])
    adapted = make_env(config)
    settings = sb3_settings(config, algo, adapted.spec)
    model = make_model(settings, algo, DummyVecEnv([lambda: adapted.env]), seed=0, device="cpu")
    return model, settings


def first_layer_sizes(module) -> list[int]:
    import torch

    return [layer.out_features for layer in module.modules() if isinstance(layer, torch.nn.Linear)][:-1]


@pytest.mark.parametrize("algo", ["sac", "ddpg", "td3"])
def test_mountaincar_zoo_entries_become_the_expected_sb3_objects(algo):
    entry = package_entry(algo, MOUNTAIN_CAR)
    model, settings = zoo_model(algo)
    try:
        assert settings.name == "zoo" and settings.zoo_entry == entry
        assert settings.unused == {"n_timesteps": entry["n_timesteps"]}  # the budget is run.steps
        assert settings.policy == entry["policy"] == "MlpPolicy"
        assert model.lr_schedule(1.0) == pytest.approx(float(entry["learning_rate"]))
        assert model.actor.optimizer.param_groups[0]["lr"] == pytest.approx(float(entry["learning_rate"]))
        for key in ("buffer_size", "batch_size", "learning_starts", "gamma", "tau", "gradient_steps"):
            if key in entry:
                assert getattr(model, key) == pytest.approx(entry[key]), key
        assert model.train_freq.frequency == entry.get("train_freq", 1)
        net_arch = keyword_literals(entry["policy_kwargs"])["net_arch"]
        assert model.actor.net_arch == net_arch
        assert first_layer_sizes(model.actor) == net_arch
        assert first_layer_sizes(model.critic.qf0) == net_arch
        if algo == "sac":
            assert model.use_sde is entry["use_sde"] is True  # the zoo's SAC explores with gSDE
            assert model.ent_coef == entry["ent_coef"]
            assert model.actor.use_sde and model.actor.log_std_init == pytest.approx(
                keyword_literals(entry["policy_kwargs"])["log_std_init"]
            )
            assert model.action_noise is None
        else:
            assert entry["noise_type"] == "ornstein-uhlenbeck" and entry["noise_std"] == 0.5
            assert isinstance(model.action_noise, OrnsteinUhlenbeckActionNoise)
            assert model.action_noise._sigma.tolist() == [entry["noise_std"]]  # one σ per action dimension
            assert model.action_noise._mu.tolist() == [0.0]
    finally:
        model.env.close()


def test_pendulum_td3_zoo_entry_has_normal_noise_and_its_own_warm_up():
    entry = package_entry("td3", "Pendulum-v1")
    model, _ = zoo_model("td3", "Pendulum-v1")
    try:
        assert isinstance(model.action_noise, NormalActionNoise)
        assert model.action_noise._sigma.tolist() == [entry["noise_std"]]
        assert model.learning_starts == entry["learning_starts"] and model.gamma == entry["gamma"]
    finally:
        model.env.close()


def test_lin_schedules_run_from_the_zoo_value_to_zero_and_stay_there():
    entry = package_entry("sac", "LunarLanderContinuous-v3")
    assert entry["learning_rate"].startswith("lin_")
    start = float(entry["learning_rate"][len("lin_") :])
    settings = zoo_settings("sac", "LunarLanderContinuous-v3", action_dim=2, obs_kind="vector")
    schedule = settings.kwargs["learning_rate"]
    assert schedule(1.0) == pytest.approx(start)
    assert schedule(0.25) == pytest.approx(0.25 * start)
    assert schedule(0.0) == 0.0 and schedule(-0.01) == 0.0  # past the budget (the last episode): zero


def test_policy_kwargs_are_parsed_as_literals_never_evaluated():
    assert parse_policy_kwargs("dict(log_std_init=-3.67, net_arch=[64, 64], use_expln=True)") == {
        "log_std_init": -3.67,
        "net_arch": [64, 64],
        "use_expln": True,
    }
    assert parse_policy_kwargs("dict(net_arch=dict(pi=[64], qf=[400, 300]), n_critics=1)") == {
        "net_arch": {"pi": [64], "qf": [400, 300]},
        "n_critics": 1,
    }
    assert parse_policy_kwargs("{'net_arch': [8], 'share_features_extractor': False}") == {
        "net_arch": [8],
        "share_features_extractor": False,
    }
    for text in (
        "dict(activation_fn=nn.ReLU)",
        "__import__('os').system('echo pwned')",
        "dict(net_arch=[64] * 2)",
        "dict(**other)",
        "[64, 64]",
        "dict(",
    ):
        with pytest.raises(ValueError) as error:
            parse_policy_kwargs(text)
        assert "\n" not in str(error.value) and "policy_kwargs" in str(error.value)


def test_every_entry_of_the_three_files_is_translated_or_refused_in_one_line():
    for algo in ("sac", "td3", "ddpg"):
        for env_id in zoo_table(algo):
            try:
                zoo_settings(algo, env_id, action_dim=2, obs_kind="vector")
            except ExperimentError as error:
                assert "\n" not in str(error) and algo in str(error) and env_id in str(error)
    with pytest.raises(ExperimentError, match=r"normalize.*VecNormalize is not implemented"):
        zoo_entry("sac", "HumanoidBulletEnv-v0")
    with pytest.raises(ExperimentError, match="env_wrapper, which is refused"):
        zoo_entry("sac", "CarRacing-v3")


def test_the_zoo_package_is_read_not_imported():
    zoo_table("ddpg")
    assert "rl_zoo3" not in sys.modules  # importing it would patch gymnasium's TimeLimit process-wide
    assert gymnasium.wrappers.TimeLimit.__module__.startswith("gymnasium.")


def test_a_task_without_a_zoo_entry_is_one_line_and_exit_2(tmp_path):
    with pytest.raises(ExperimentError) as error:
        zoo_entry("ddpg", "Acrobot-v1")
    message = str(error.value)
    version = importlib.metadata.version("rl-zoo3")
    assert message.startswith(f"RL Zoo {version} has no ddpg hyperparameters for 'Acrobot-v1' (")
    assert MOUNTAIN_CAR in message and "\n" not in message
    data = {
        "name": "nico-zoo",
        "rewards": ["sparse"],
        "seeds": 1,
        "steps": 100,
        "methods": [
            {"label": "SB3-SAC-zoo", "algo": "sb3-sac", "overrides": {"agent.sb3_hyperparams": "zoo"}}
        ],
    }
    with pytest.raises(ExperimentError, match=r"no sac hyperparameters for 'dualsys/NicoGrasp-v0'"):
        load_experiment(data)
    path = tmp_path / "nico-zoo.yaml"
    path.write_text(yaml.safe_dump(data))
    result = CliRunner().invoke(app, ["experiment", "run", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.stderr.strip().count("\n") == 0
    assert result.stderr.startswith(
        f"error: method 'SB3-SAC-zoo', sparse reward: RL Zoo {version} has no sac hyperparameters for "
        "'dualsys/NicoGrasp-v0'"
    )
    assert not (tmp_path / "out").exists()
