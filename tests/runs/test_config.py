"""Config profiles, overrides, files, coercion and the unknown-key error (core/config.py)."""

from __future__ import annotations

import json

import pytest

from core.config import PAPER_DUAL_OVERRIDES, PROFILES, Config, ConfigError, check_config, load_config


def test_paper_profile_holds_section_4_1_1_values():
    paper = load_config("paper")
    assert (paper.agent.lambda_rec, paper.agent.lambda_q) == (0.1, 1.0)
    assert (paper.agent.gamma, paper.agent.tau) == (0.99, 1e-6)
    assert (paper.agent.critic_lr, paper.agent.actor_lr, paper.agent.batch_size) == (1e-3, 1e-4, 256)
    assert paper.agent.buffer_size == 100_000
    assert paper.net.arch == "paper" and paper.net.conv_channels == (16, 8, 4) and paper.net.latent_dim == 32
    assert paper.agent.update_schedule == "per_episode"
    agent = paper.agent
    assert (agent.critic_passes, agent.cacla_actor_passes, agent.ddpg_actor_passes) == (5, 15, 5)
    assert paper.agent.noise_std == paper.agent.noise_final_std == 1.0
    assert (paper.dual.e_max, paper.dual.lp_sigma, paper.dual.lp_window, paper.dual.d_max) == (6.0, 40, 20, 6)
    assert (paper.dual.plan_steps, paper.dual.plan_lr) == (10, 1e-3)
    assert (paper.dual.pixel_buffer_size, paper.dual.latent_buffer_size) == (60_000, 200_000)
    assert paper.run.episodes == 10_000 and paper.env.max_steps == 50
    # the text is explicit where the released code differs: random positions, −d shaping, learned hand
    env = paper.env
    assert (env.fixed_positions, env.dense_shaping, env.hand) == (None, "distance", "learned")


def test_paper_dual_section_is_the_literal_reading_and_the_default_has_every_repair_on():
    paper, default = load_config("paper").dual, load_config("default").dual
    literal = {"region_space": "latent", "model_space": "latent", "region_prune_after": 0,
               "reliability": "lp", "intrinsic_signal": "neg_lp", "intrinsic_region": "source",
               "model_target": "absolute",
               "model_termination": False, "model_batch": 1, "model_memory": 0, "new_node_model": "fresh",
               "refit_every": 0, "plan_optimiser": "sgd", "plan_clip": "executed",
               "imagination_source": "act_time", "imagination_gate": "none"}
    for key, value in literal.items():
        assert getattr(paper, key) == value, key
        assert getattr(default, key) != value, key
    assert load_config("default", list(PAPER_DUAL_OVERRIDES)).dual == paper
    # the released sigmoid output applies to the paper's absolute model only; a delta model stays linear
    from core.dual.world_models import effective_model_output

    released_delta = load_config("default", ["dual.model_output=released", "dual.model_space=latent"])
    check_config(released_delta)
    assert effective_model_output(released_delta.dual) == "linear"
    assert effective_model_output(paper) == paper.model_output


def test_profiles_are_fresh_objects():
    first = PROFILES["default"]()
    first.agent.batch_size = 3
    assert PROFILES["default"]().agent.batch_size != 3


def test_overrides_are_coerced_to_field_types():
    config = load_config(
        "default",
        [
            "agent.batch_size=32",
            "agent.tau=1e-3",
            "run.steps=none",
            "net.conv_channels=8,8",
            "run.final_eval=false",
            "env.fixed_positions=50",
            "run.max_wall_s=90",
        ],
    )
    assert config.agent.batch_size == 32 and isinstance(config.agent.batch_size, int)
    assert config.agent.tau == pytest.approx(1e-3)
    assert config.run.steps is None
    assert config.net.conv_channels == (8, 8)
    assert config.run.final_eval is False
    assert config.env.fixed_positions == 50
    assert config.run.max_wall_s == 90.0


@pytest.mark.parametrize(
    ("override", "fragment"),
    [
        ("agent.nope=1", "agent.nope"),
        ("nosection.x=1", "nosection.x"),
        ("agent.batch_size=abc", "agent.batch_size"),
        ("agent.batch_size=1.5", "agent.batch_size"),
        ("env.reward_mode=medium", "env.reward_mode"),
        ("run.final_eval=maybe", "run.final_eval"),
        ("justtext", "justtext"),
    ],
)
def test_bad_overrides_raise_config_error_naming_the_key(override, fragment):
    with pytest.raises(ConfigError, match=fragment.replace(".", r"\.")):
        load_config("default", [override])


def test_unknown_profile():
    with pytest.raises(ConfigError, match="unknown profile"):
        load_config("fastest")


def test_yaml_and_json_files_apply_between_profile_and_overrides(tmp_path):
    yaml_file = tmp_path / "c.yaml"
    yaml_file.write_text("agent:\n  batch_size: 16\n  gamma: 0.9\nenv:\n  reward_mode: sparse\n")
    config = load_config("paper", ["agent.gamma=0.5"], yaml_file)
    assert (config.agent.batch_size, config.agent.gamma, config.env.reward_mode) == (16, 0.5, "sparse")
    assert config.agent.tau == 1e-6  # untouched paper value
    json_file = tmp_path / "c.json"
    json_file.write_text(json.dumps({"dual": {"e_max": 3}}))
    assert load_config("default", [], json_file).dual.e_max == 3.0
    bad = tmp_path / "bad.yaml"
    bad.write_text("agent:\n  learning_rate: 1\n")
    with pytest.raises(ConfigError, match=r"agent\.learning_rate"):
        load_config("default", [], bad)
    with pytest.raises(ConfigError, match="not found"):
        load_config("default", [], tmp_path / "missing.yaml")


def test_dict_round_trip_and_yaml_text():
    config = load_config("paper", ["net.conv_channels=4,2", "run.seed=7"])
    assert Config.from_dict(config.to_dict()) == config
    assert "conv_channels:\n  - 4\n  - 2" in config.to_yaml()


def test_range_checks():
    config = load_config("default", ["agent.batch_size=0"])
    with pytest.raises(ConfigError, match=r"agent\.batch_size"):
        check_config(config)
    with pytest.raises(ConfigError, match="budget"):
        check_config(load_config("default", ["run.episodes=none"]))
    check_config(load_config("paper"))


def test_the_vector_profile_differs_from_default_only_in_net_and_agent():
    default, vector = load_config("default").to_dict(), load_config("vector").to_dict()
    assert vector["dual"] == default["dual"] and vector["run"] == default["run"]
    assert vector["env"] == default["env"]
    assert vector["net"]["encoder"] == "none" and vector["net"]["mlp_hidden"] == [256, 256]
    assert vector["agent"]["critic_lr"] == vector["agent"]["actor_lr"] == 1e-3
