"""The six mechanism checks (issue #19, docs/dual-system.md "Mechanisms"): each goal holds under the default
profile (the repairs), and the paper profile's literal reading shows the failure the repair addresses.

`dualsys diagnose mechanisms --quick --json` runs once for the module (the quick sizes of the command's
checks); the paper-side contrasts call the check functions at small sizes.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from core.config import load_config
from core.dual.checks.imagination import imagination_check
from core.dual.checks.intrinsic import intrinsic_check
from core.dual.checks.planner import planner_check
from core.dual.checks.regions import regions_check
from core.dual.checks.reliability import STREAMS, real_model_change, reliability_check, trusted_share
from core.dual.checks.world_model import error_ratio, world_model_check
from core.dual.readings import WORLD_MODELS, resolve
from core.envs import NicoGraspEnv
from core.envs.spec import EnvSpec
from core.modelfree.learners import make_learner
from dualsys_cli.main import app

KEYS = {
    "profile": None,
    "world_model": {"error_ratio_to_no_change"},
    "reliability": {"trusted_when_improving", "trusted_when_accurate", "trusted_when_unlearnable"},
    "intrinsic": {"learnable_share", "learned_share", "noise_share", "learnable_share_without_rint"},
    "planner": {"toward_reward_share", "shift_over_noise_std"},
    "regions": {"nodes_by_latent_scale"},
    "imagination": {"critic_error_real_only", "critic_error_true_model", "critic_error_no_change_model"},
}


@pytest.fixture(scope="module")
def figures() -> dict:
    torch.set_num_threads(1)
    result = CliRunner().invoke(app, ["diagnose", "mechanisms", "--quick", "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.output)


@pytest.fixture(scope="module")
def paper():
    return load_config("paper")


def test_command_prints_exactly_the_contract_keys(figures) -> None:
    assert list(figures) == list(KEYS)
    assert figures["profile"] == "default"
    for check, keys in KEYS.items():
        if keys is not None:
            assert set(figures[check]) == keys, check
    assert set(figures["regions"]["nodes_by_latent_scale"]) == {"0.01", "1", "100"}


def test_unknown_profile_is_a_one_line_user_error() -> None:
    result = CliRunner().invoke(app, ["diagnose", "mechanisms", "--profile", "nope"])
    assert result.exit_code == 2 and "unknown profile 'nope'" in result.output


def test_world_models_beat_nothing_changes_and_the_literal_ones_do_not(figures, paper) -> None:
    assert figures["world_model"]["error_ratio_to_no_change"] <= 0.4  # goal 0.5
    assert world_model_check(paper.dual, steps=1000, seeds=1)["error_ratio_to_no_change"] > 1.2


def _nico_grasp_latents(steps: int = 1200) -> list[tuple]:
    """Random-action NicoGrasp transitions (one glass position) through a frozen, untrained default encoder
    (latent changes of about 0.005); the reward is set to 0 so the ratio measures the latent prediction."""
    env = NicoGraspEnv(level="released", reward_mode="sparse", fixed_positions=1)
    rng = np.random.default_rng(0)
    frames, actions, nexts = [], [], []
    obs, _ = env.reset(seed=0)
    try:
        for _ in range(steps):
            action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
            nxt, _, terminated, truncated, _ = env.step(action)
            frames.append(obs)
            actions.append(action)
            nexts.append(nxt)
            obs = env.reset(seed=int(rng.integers(1 << 30)))[0] if terminated or truncated else nxt
    finally:
        env.close()
    config = load_config("default")
    torch.manual_seed(0)
    spec = EnvSpec(obs_shape=(32, 64, 3), action_dim=actions[0].shape[0])
    learner = make_learner(config.net, config.agent, spec)
    with torch.no_grad():
        phi = learner.encode(torch.from_numpy(np.stack(frames))).numpy()
        nxt = learner.encode(torch.from_numpy(np.stack(nexts))).numpy()
    return list(zip(phi, actions, [0.0] * steps, nxt, strict=True))


def test_world_models_on_frozen_nico_grasp_latents(paper) -> None:
    """1200 transitions over ~20 regions of an untrained encoder's latents is too little for any model to beat
    "nothing changes" by much (docs/dual-system.md): the repaired models stay near it, where models in raw
    latent units (Adam's steps of 1e-3 against changes of 0.005) or fresh per-region models are far worse."""
    stream = _nico_grasp_latents()
    latent_dim, action_dim = stream[0][0].shape[0], stream[0][1].shape[0]
    repaired = error_ratio(load_config("default").dual, stream, latent_dim, action_dim)
    default = load_config("default").dual
    raw = dataclasses.replace(WORLD_MODELS["repaired"], space="latent")  # the repaired models in raw units
    raw_units = error_ratio(default, stream, latent_dim, action_dim,
                            readings=dataclasses.replace(resolve(default), world_models=raw))
    literal = error_ratio(paper.dual, stream, latent_dim, action_dim)
    assert repaired < 1.2 and repaired < literal and 1.5 * repaired < raw_units


def test_reliability_trusts_accurate_and_improving_models_and_not_unlearnable_ones(figures) -> None:
    reliability = figures["reliability"]
    assert reliability["trusted_when_improving"] >= 0.9
    assert reliability["trusted_when_accurate"] >= 0.9
    assert reliability["trusted_when_unlearnable"] <= 0.1
    assert trusted_share(load_config("default").dual, STREAMS["rising"], 400, 0) <= 0.15


def test_paper_reliability_is_a_coin_flip(paper) -> None:
    shares = reliability_check(paper.dual, seeds=1)
    assert all(0.35 <= share <= 0.7 for share in shares.values()), shares


def test_a_real_model_loses_trust_when_the_dynamics_change_and_regains_it(paper) -> None:
    repaired = real_model_change(load_config("default").dual, steps=2000)
    assert repaired["before_change"] >= 0.8 and repaired["end"] >= 0.8
    assert repaired["just_after_change"] <= 0.2
    literal = real_model_change(paper.dual, steps=2000)
    assert literal["just_after_change"] >= 0.3  # LP ≥ 0 half the time whatever happens


def test_intrinsic_reward_prefers_the_learnable_region(figures, paper) -> None:
    shares = figures["intrinsic"]
    assert shares["learnable_share"] > shares["learned_share"] + 0.3
    assert shares["learnable_share"] > shares["noise_share"] + 0.3
    assert shares["learnable_share"] >= 1.5 * shares["learnable_share_without_rint"]
    literal = intrinsic_check(paper.dual, steps=3000, seeds=1)
    assert literal["noise_share"] > 2 * shares["noise_share"]  # −LP rewards rising error: the noisy TV


def test_planner_moves_the_plan_toward_reward_by_more_than_a_rounding(figures, paper) -> None:
    assert figures["planner"]["toward_reward_share"] >= 0.95
    assert figures["planner"]["shift_over_noise_std"] >= 0.4  # goal 0.2
    assert planner_check(paper, starts=30, transitions=500)["shift_over_noise_std"] < 0.1


def test_regions_do_not_depend_on_the_latent_scale(figures, paper) -> None:
    nodes = figures["regions"]["nodes_by_latent_scale"].values()
    assert max(nodes) <= 1.25 * min(nodes) and min(nodes) >= 5
    literal = regions_check(paper.dual, states=1000)["nodes_by_latent_scale"]
    assert literal["100"] > 50 * literal["0.01"]


def test_imagination_helps_with_the_true_model_and_is_gated_off_for_no_change(figures, paper) -> None:
    errors = figures["imagination"]
    assert errors["critic_error_true_model"] < 0.5 * errors["critic_error_real_only"]
    assert errors["critic_error_no_change_model"] <= 1.1 * errors["critic_error_real_only"]
    literal = imagination_check(paper.dual, seeds=1, updates=300)
    assert literal["critic_error_no_change_model"] > 2 * literal["critic_error_real_only"]
