"""The paper's learners: Eq. 1-4 updates, the CACLA δ > 0 rule, DDPG leaving the critic alone, τ-exact target
updates."""

from __future__ import annotations

import copy

import pytest
import torch

from core.config import load_config
from core.envs.spec import EnvSpec
from core.modelfree.learners import Learner, make_learner
from core.modelfree.learners.base import soft_update
from core.modelfree.networks import ActionBounds, Actor, Encoder, PolicyNetwork, multiply_adds_per_image
from core.modelfree.replay import PixelBatch

NICO_SPEC = EnvSpec(obs_shape=(32, 64, 3), action_dim=1)

TINY = ["net.conv_channels=4,4", "net.latent_dim=8", "net.critic_hidden=8", "net.actor_hidden=8"]


def learner(ac: str = "ddpg", extra: tuple[str, ...] = ()) -> Learner:
    torch.manual_seed(0)
    config = load_config("default", [*TINY, f"agent.ac={ac}", *extra])
    return make_learner(config.net, config.agent, NICO_SPEC)


def batch(size: int = 16, seed: int = 0) -> PixelBatch:
    generator = torch.Generator().manual_seed(seed)
    obs = torch.randint(0, 256, (size, 32, 64, 3), dtype=torch.uint8, generator=generator)
    next_obs = torch.randint(0, 256, (size, 32, 64, 3), dtype=torch.uint8, generator=generator)
    action = torch.rand(size, 1, generator=generator) * 2 - 1
    reward = torch.rand(size, generator=generator) - 0.5
    terminated = (torch.rand(size, generator=generator) < 0.2).float()
    return PixelBatch(obs, action, reward, next_obs, terminated, reward)


def test_td_target_is_eq_1_with_termination():
    ac = learner()
    data = batch()
    with torch.no_grad():
        phi_next = ac.target_encoder(data.next_obs.permute(0, 3, 1, 2).float() / 255)
        q_next = ac.target_critic(phi_next, ac.target_actor(phi_next))
    target = ac.td_target(data.reward, phi_next, data.terminated)
    expected = data.reward + 0.99 * (1 - data.terminated) * q_next
    assert torch.allclose(target, expected)
    assert torch.allclose(target[data.terminated.bool()], data.reward[data.terminated.bool()])


def test_combined_loss_falls_on_a_fixed_batch():
    ac = learner(extra=("agent.critic_lr=3e-3",))
    data = batch(32)
    first = ac.update(data)
    for _ in range(60):
        last = ac.update(data)
    assert last["losses/critic"] < 0.5 * first["losses/critic"]
    assert last["losses/rec"] < first["losses/rec"]


def test_cacla_moves_the_actor_only_on_positive_td_samples():
    ac = learner("cacla", ("agent.cacla_actor_passes=3", "agent.actor_lr=1e-2"))
    generator = torch.Generator().manual_seed(1)
    latent = torch.rand(12, 8, generator=generator)
    action = torch.rand(12, 1, generator=generator) * 2 - 1
    with torch.no_grad():
        on_policy_value = ac.critic(latent, ac.actor(latent))
    sign = torch.tensor([1.0, -1.0, 1.0, -1.0, -1.0, 1.0, -1.0, -1.0, 1.0, -1.0, -1.0, -1.0])
    target = on_policy_value + 0.1 * sign  # δ = target − Q(φ, μ(φ)) = 0.1·sign
    positive = sign > 0
    assert torch.equal(ac.positive_mask(latent, target), positive)

    reference = copy.deepcopy(ac)
    changed_negatives = action.clone()
    changed_negatives[~positive] = -changed_negatives[~positive]  # actions where δ ≤ 0 must not matter
    result = ac.policy_step(latent, changed_negatives, target)
    assert result.positive_fraction == pytest.approx(positive.float().mean().item())

    # The same update done by hand on the positive samples only (Eq. 3).
    for _ in range(3):
        loss = (reference.actor(latent[positive]) - action[positive]).pow(2).sum(1).mean()
        reference.actor_optimizer.zero_grad()
        loss.backward()
        reference.actor_optimizer.step()
    for mine, theirs in zip(ac.actor.parameters(), reference.actor.parameters(), strict=True):
        assert torch.allclose(mine, theirs, atol=1e-7)
    # The positive samples' outputs moved toward a_t (their squared error fell).
    fresh = learner("cacla")
    with torch.no_grad():
        after = (ac.actor(latent[positive]) - action[positive]).pow(2).mean()
        start = (fresh.actor(latent[positive]) - action[positive]).pow(2).mean()
    assert after < start


def test_cacla_with_no_positive_td_leaves_the_actor_unchanged():
    ac = learner("cacla", ("agent.cacla_actor_passes=5",))
    latent = torch.rand(6, 8)
    with torch.no_grad():
        target = ac.critic(latent, ac.actor(latent)) - 0.5
    before = [p.clone() for p in ac.actor.parameters()]
    result = ac.policy_step(latent, torch.zeros(6, 1), target)
    assert result.positive_fraction == 0.0
    for old, new in zip(before, ac.actor.parameters(), strict=True):
        assert torch.equal(old, new)


def test_ddpg_actor_step_ascends_q_and_leaves_critic_untouched():
    ac = learner("ddpg", ("agent.actor_lr=1e-2", "agent.ddpg_actor_passes=20"))
    latent = torch.rand(32, 8)
    critic_before = [p.clone() for p in ac.critic.parameters()]
    with torch.no_grad():
        q_before = ac.critic(latent, ac.actor(latent)).mean()
    ac.policy_step(latent, torch.zeros(32, 1), torch.zeros(32))
    with torch.no_grad():
        q_after = ac.critic(latent, ac.actor(latent)).mean()
    assert q_after > q_before  # Eq. 2: gradient ascent on Q
    for old, new in zip(critic_before, ac.critic.parameters(), strict=True):
        assert torch.equal(old, new)
    assert all(p.requires_grad for p in ac.critic.parameters())


def test_soft_update_is_tau_exact():
    torch.manual_seed(3)
    online, target = torch.nn.Linear(5, 4), torch.nn.Linear(5, 4)
    old = [p.detach().clone() for p in target.parameters()]
    soft_update(target, online, 0.25)
    for before, now, source in zip(old, target.parameters(), online.parameters(), strict=True):
        assert torch.allclose(now, 0.25 * source + 0.75 * before, atol=1e-7, rtol=0)
    soft_update(target, online, 1.0)
    for now, source in zip(target.parameters(), online.parameters(), strict=True):
        assert torch.equal(now, source)


def test_update_moves_targets_by_tau_only():
    ac = learner(extra=("agent.tau=0.1",))
    target_before = [p.clone() for p in ac.target_critic.parameters()]
    ac.update(batch())
    for before, now, online in zip(
        target_before, ac.target_critic.parameters(), ac.critic.parameters(), strict=True
    ):
        assert torch.allclose(now, before + 0.1 * (online - before), atol=1e-6)


def test_action_bounds_are_buffers_and_policy_network_takes_uint8():
    config = load_config("default", TINY)
    bounds = ActionBounds([-0.5, 2.0], [0.5, 4.0])
    assert {"low", "high"} <= set(dict(bounds.named_buffers()))
    network = PolicyNetwork(Encoder(config.net), Actor(8, 2, (8,), "relu"), bounds)
    actions = network(torch.randint(0, 256, (3, 32, 64, 3), dtype=torch.uint8))
    assert actions.shape == (3, 2)
    assert actions[:, 0].abs().max() <= 0.5 and bool(((actions[:, 1] >= 2.0) & (actions[:, 1] <= 4.0)).all())
    # [-1, 1] maps onto [low, high] exactly at the ends and the middle; ±1 bounds are the identity
    assert torch.allclose(bounds(torch.tensor([[-1.0, -1.0], [0.0, 0.0], [1.0, 1.0]])),
                          torch.tensor([[-0.5, 2.0], [0.0, 3.0], [0.5, 4.0]]))
    unit = ActionBounds([-1.0], [1.0])
    x = torch.tensor([[0.123456789]])
    assert unit.identity and unit(x) is x


def test_strided_encoder_is_cheaper_than_the_paper_shape():
    paper, default = load_config("paper"), load_config("default")
    assert multiply_adds_per_image(Encoder(default.net)) * 3 < multiply_adds_per_image(Encoder(paper.net))
    assert Encoder(paper.net)(torch.zeros(2, 3, 32, 64)).shape == (2, 32)
