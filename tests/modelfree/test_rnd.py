"""Random network distillation (core/modelfree/rnd.py): its definition and the property it is used for."""

from __future__ import annotations

import numpy as np
import torch

from core.config import load_config
from core.envs.spec import EnvSpec
from core.modelfree.rnd import RandomNetworkDistillation, RNDAgent, RunningMeanStd

SPEC = EnvSpec(obs_shape=(4,), action_dim=1, obs_kind="vector", obs_dtype="float32")
CONFIG = load_config(
    "default", ["net.mlp_hidden=32,32", "net.latent_dim=16", "agent.rnd_dim=16", "agent.rnd_lr=1e-3"]
)


def test_the_bonus_is_the_predictors_squared_error_to_the_fixed_target():
    rnd = RandomNetworkDistillation(CONFIG, SPEC, generator_seed=0)
    obs = torch.randn(8, 4)
    x = ((obs - rnd.obs_stats.mean) / rnd.obs_stats.std()).clamp(-5, 5)
    expected = (rnd.predictor(x) - rnd.target(x)).pow(2).sum(1)
    assert torch.allclose(rnd.error(obs), expected)
    target_before = [p.clone() for p in rnd.target.parameters()]
    for _ in range(5):
        rnd.bonus_and_update(obs)
    assert all(torch.equal(a, b) for a, b in zip(target_before, rnd.target.parameters(), strict=True))
    assert all(not p.requires_grad for p in rnd.target.parameters())


def test_a_visited_observation_loses_its_bonus_and_a_novel_one_keeps_it():
    torch.manual_seed(0)
    rnd = RandomNetworkDistillation(CONFIG, SPEC, generator_seed=1)
    familiar = torch.randn(64, 4) * 0.3
    novel = torch.randn(64, 4) * 0.3 + torch.tensor([3.0, -3.0, 3.0, -3.0])
    rnd.observe(torch.cat([familiar, novel]))
    with torch.no_grad():
        before_familiar = float(rnd.error(familiar).mean())
    for _ in range(200):
        rnd.bonus_and_update(familiar)
    with torch.no_grad():
        after_familiar, after_novel = float(rnd.error(familiar).mean()), float(rnd.error(novel).mean())
    assert after_familiar < 0.05 * before_familiar  # measured 0.004 of it
    assert after_novel > 10 * after_familiar  # measured 66x


def test_running_mean_std_matches_numpy_over_batches():
    stats = RunningMeanStd((3,))
    data = np.random.default_rng(0).normal([1.0, -2.0, 5.0], [0.5, 2.0, 3.0], (500, 3))
    for chunk in np.array_split(data, 7):
        stats.update(torch.tensor(chunk, dtype=torch.float32))
    np.testing.assert_allclose(stats.mean.numpy(), data.mean(0), rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(stats.var.numpy(), data.var(0), rtol=1e-3)


def test_the_agent_adds_the_bonus_at_learn_time_and_resumes_it():
    agent = RNDAgent(CONFIG, SPEC, np.random.default_rng(0))
    state = agent.state_dict()
    restored = RNDAgent(CONFIG, SPEC, np.random.default_rng(1))
    restored.load_state_dict(state)
    obs = torch.randn(5, 4)
    assert torch.allclose(agent.rnd.error(obs), restored.rnd.error(obs))
