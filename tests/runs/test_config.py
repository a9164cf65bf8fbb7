"""Config profiles, overrides, files, coercion and the unknown-key error (core/config.py)."""

from __future__ import annotations

import json

import pytest

from core.config import PROFILES, Config, ConfigError, check_config, load_config
from tests.utils.paper_dual import paper_dual_overrides


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
    assert paper.dual.latent_buffer_size == 200_000  # B_pixel is agent.buffer_size, as every method's replay
    assert paper.run.episodes == 10_000 and paper.env.max_steps == 50
    # the text is explicit where the released code differs: random positions, −d shaping, learned hand
    env = paper.env
    assert (env.fixed_positions, env.dense_shaping, env.hand) == (None, "distance", "learned")


OLD_BY_MECHANISM = {  # old key: (the reading's attribute, `paper` profile's old value, `default`'s old value)
    "regions": {"region_space": ("space", "latent", "normalised"), "itm_distance": ("distance", "l2", "l2")},
    "world_models": {"model_space": ("space", "latent", "normalised"),
                     "model_target": ("target", "absolute", "delta"),
                     "model_output": ("output", "linear", "linear"),
                     "new_node_model": ("new_node", "fresh", "parent")},
    "reliability": {"reliability": ("signal", "lp", "heldout"), "error_norm": ("error_norm", "l2", "l2"),
                    "lp_normalise": ("lp_normalise", True, True),
                    "lp_warmup": ("lp_warmup", "zero_oldest", "zero_oldest")},
    "intrinsic": {"intrinsic_signal": ("signal", "neg_lp", "progress"),
                  "intrinsic_region": ("region", "source", "destination")},
    "planner": {"plan_optimiser": ("optimiser", "sgd", "normalised"),
                "plan_clip": ("clip", "executed", "every_step"),
                "plan_objective": ("objective", "sum", "sum")},
    "imagination": {"imagination_source": ("source", "act_time", "learn_time"),
                    "imagination_gate": ("gate", "none", "no_change_ratio"),
                    "model_termination": ("termination", False, True)},
}
OLD_SWITCHES = {key: (mechanism, *row) for mechanism, rows in OLD_BY_MECHANISM.items()
                for key, row in rows.items()}
"""The 18 switches the readings replaced, with each profile's value before the change (the other three:
``arbitration`` stayed a field, ``imagination_reward = model`` and ``imagination_actor = all`` are what every
reading does now)."""

OLD_HELD_OUT = {"heldout_size": ("size", 48), "heldout_every": ("every", 4), "reliability_lag": ("lag", 100),
                "reliability_z": ("z", 3.0), "accurate_ratio": ("accurate_ratio", 0.5)}


@pytest.mark.parametrize("profile", ["paper", "default"])
def test_profiles_resolve_to_exactly_their_old_switch_values(profile):
    from core.dual.readings import resolve

    dual = load_config(profile).dual
    readings = resolve(dual)
    for key, (mechanism, attribute, paper, default) in OLD_SWITCHES.items():
        got = getattr(getattr(readings, mechanism), attribute)
        assert got == (paper if profile == "paper" else default), key
    for key, (attribute, value) in OLD_HELD_OUT.items():
        assert getattr(readings.held_out, attribute) == value, key
    assert dual.arbitration == "lp"
    expected = {"regions": "released", "world_models": "paper", "reliability": "released",
                "intrinsic": "paper", "planner": "paper", "imagination": "paper"}
    for mechanism, reading in expected.items():
        assert getattr(dual, mechanism) == (reading if profile == "paper" else "repaired"), mechanism


def test_paper_dual_overrides_turn_the_default_into_the_paper_dual_section():
    paper = load_config("paper").dual
    overrides = paper_dual_overrides()
    assert load_config("default", overrides).dual == paper
    removed = set(OLD_SWITCHES) - {"reliability"}  # the one old key that kept its name
    assert not {key.split("=")[0].removeprefix("dual.") for key in overrides} & removed
    assert "dual.reliability=released" in overrides


def test_each_reading_holds_the_old_values_it_names():
    from core.dual import readings as r

    assert r.REGIONS["paper"] == r.Regions(space="latent", distance="squared")
    assert r.WORLD_MODELS["released"] == r.WorldModels(space="latent", target="absolute",
                                                       output="released", new_node="fresh")
    # the released sigmoid heads only with the absolute raw-latent model: every other reading is linear
    assert {w.output for name, w in r.WORLD_MODELS.items() if name != "released"} == {"linear"}
    assert r.RELIABILITY["paper"] == r.Reliability(signal="lp", error_norm="squared", lp_normalise=False,
                                                   lp_warmup="unreliable")
    assert r.PLANNER["released"] == r.Planner(objective="per_step", optimiser="sgd", clip="executed")
    no_head = r.Imagination(source="learn_time", gate="no_change_ratio", termination=False)
    assert r.IMAGINATION["repaired_no_termination"] == no_head
    for mechanism, table in r.TABLES.items():  # every reading is one distinct combination
        assert len(set(table.values())) == len(table), mechanism


@pytest.mark.parametrize("key", [*OLD_SWITCHES, *OLD_HELD_OUT, "imagination_reward", "imagination_actor"])
def test_a_removed_dual_key_is_a_one_line_error_naming_what_replaced_it(key, tmp_path):
    if key == "reliability":
        with pytest.raises(ConfigError, match=r"bad value for dual\.reliability: 'lp'"):
            load_config("default", ["dual.reliability=lp"])
        return
    with pytest.raises(ConfigError) as error:
        load_config("default", [f"dual.{key}=1"])
    message = str(error.value)
    assert "\n" not in message and message.startswith(f"unknown config key 'dual.{key}'")
    if key in OLD_SWITCHES:
        assert f"now dual.{OLD_SWITCHES[key][0]}," in message
    file = tmp_path / "old.yaml"
    file.write_text(f"dual:\n  {key}: 1\n")
    with pytest.raises(ConfigError, match=f"unknown config key 'dual.{key}'"):
        load_config("default", file=file)


def test_a_scale_free_e_max_is_a_raw_latent_resolution_refused_with_a_normalised_map():
    for regions in ("paper", "released"):
        check_config(load_config("default", ["dual.e_max_relative=1.0", f"dual.regions={regions}"]))
    with pytest.raises(ConfigError, match=r"set dual\.regions=released"):
        check_config(load_config("default", ["dual.e_max_relative=1.0", "dual.regions=repaired"]))


def test_a_stored_config_in_the_old_switches_is_read_as_its_readings():
    from core.dual.readings import upgrade_stored

    for profile in ("paper", "default"):
        stored = Config.from_dict({}, base=load_config(profile)).to_dict()
        fields = ("regions", "world_models", "reliability", "intrinsic", "planner", "imagination")
        dual = {key: value for key, value in stored["dual"].items() if key not in fields}
        column = 2 if profile == "paper" else 3
        dual.update({key: row[column] for key, row in OLD_SWITCHES.items()})
        dual.update({key: value for key, (_, value) in OLD_HELD_OUT.items()})
        dual.update(imagination_reward="model", imagination_actor="all")
        old = {**stored, "dual": dual}
        assert Config.from_dict(upgrade_stored(old)).dual == load_config(profile).dual
        assert upgrade_stored(stored) == stored  # the new words pass unchanged
    # the literal IM2C of mountaincar-repairs: the termination head off, the gate's held-out sets kept
    old = {"dual": {"model_termination": False}}
    assert upgrade_stored(old)["dual"] == {"imagination": "repaired_no_termination"}
    with pytest.raises(ConfigError, match=r"no reading of dual\.planner"):
        upgrade_stored({"dual": {"plan_optimiser": "adam"}})
    with pytest.raises(ConfigError, match="imagination_actor"):
        upgrade_stored({"dual": {"imagination_actor": "real"}})


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
