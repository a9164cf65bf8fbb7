"""Our learners' minibatch updates against Stable-Baselines3's, the reference implementation (issue 28).

From identical weights, on identical minibatches (and, for TD3's smoothing and SAC's sampling, identical
Gaussian draws), our DDPG, TD3 and SAC must move every network exactly as SB3's ``train()`` does: the same
TD target, loss scale, update order, policy delay, temperature step and Polyak averaging. A difference in any
of them shows up as a parameter gap far above float32 round-off within a few updates. SB3's own sampling is
replaced by the test's minibatch (``replay_buffer.sample``) and, for SAC, its Gaussian draws by the test's
(``Normal.rsample``); nothing of ours is replaced.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

from core.config import load_config
from core.envs.gym_env import adapt, make_gym_env
from core.modelfree.learners import make_learner
from core.modelfree.replay import PixelBatch

sb3 = pytest.importorskip("stable_baselines3", reason="the bench extra holds Stable-Baselines3")
from stable_baselines3.common.buffers import ReplayBufferSamples  # noqa: E402
from stable_baselines3.common.logger import configure  # noqa: E402

ENV = "MountainCarContinuous-v0"
HIDDEN = [32, 24]
BATCH = 64
UPDATES = 12
TOLERANCE = 2e-5
"""Largest parameter gap allowed after the updates (float32 round-off of differently ordered sums)."""


def _linears(module: nn.Module) -> list[nn.Linear]:
    return [m for m in module.modules() if isinstance(m, nn.Linear)]


def _pairs(ac: str, reference, ours) -> list[tuple[nn.Module, nn.Module]]:
    """(SB3 module, our module) with the same layers in the same order."""
    if ac == "sac":
        actor = nn.ModuleList([reference.actor.latent_pi, reference.actor.mu, reference.actor.log_std])
        pairs = [(actor, ours.actor)]
    else:
        pairs = [(reference.actor.mu, ours.actor), (reference.actor_target.mu, ours.target_actor)]
    critics = [reference.critic.qf0, *([reference.critic.qf1] if ac != "ddpg" else [])]
    targets = [reference.critic_target.qf0, *([reference.critic_target.qf1] if ac != "ddpg" else [])]
    return [*pairs, (nn.ModuleList(critics), ours.critic), (nn.ModuleList(targets), ours.target_critic)]


@torch.no_grad()
def _gap(pairs) -> float:
    gaps = []
    for theirs, mine in pairs:
        for a, b in zip(_linears(theirs), _linears(mine), strict=True):
            gaps += [float((a.weight - b.weight).abs().max()), float((a.bias - b.bias).abs().max())]
    return max(gaps)


def _models(ac: str):
    """SB3's model and our learner with SB3's initial weights, both at SB3's defaults for ``ac``."""
    algo = {"ddpg": sb3.DDPG, "td3": sb3.TD3, "sac": sb3.SAC}[ac]
    lr = 3e-4 if ac == "sac" else 1e-3
    reference = algo("MlpPolicy", gym.make(ENV), learning_rate=lr, batch_size=BATCH, seed=0, device="cpu",
                     policy_kwargs={"net_arch": HIDDEN})
    reference.set_logger(configure(None, []))
    overrides = [f"agent.ac={ac}", f"net.mlp_hidden={HIDDEN}", "net.observation_scaling=none",
                 f"agent.critic_lr={lr}", f"agent.actor_lr={lr}", f"agent.batch_size={BATCH}"]
    config = load_config("vector", overrides)
    ours = make_learner(config.net, config.agent, adapt(make_gym_env(ENV)).spec)
    pairs = _pairs(ac, reference, ours)
    with torch.no_grad():
        for theirs, mine in pairs:
            for a, b in zip(_linears(theirs), _linears(mine), strict=True):
                b.weight.copy_(a.weight)
                b.bias.copy_(a.bias)
    assert _gap(pairs) == 0.0
    return reference, ours, pairs


def _minibatch(rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    obs = rng.uniform([-1.2, -0.07], [0.6, 0.07], size=(BATCH, 2)).astype(np.float32)
    next_obs = (obs + rng.normal(0.0, 0.01, size=(BATCH, 2))).astype(np.float32)
    action = rng.uniform(-1.0, 1.0, size=(BATCH, 1)).astype(np.float32)
    reward = (-0.1 * action[:, 0] ** 2 + 100.0 * (rng.random(BATCH) < 0.05)).astype(np.float32)
    terminated = (rng.random(BATCH) < 0.05).astype(np.float32)
    return obs, action, reward, next_obs, terminated


def _queued_rsample(draws: list[torch.Tensor]):
    """A ``Normal.rsample`` drawing the queued standard-normal tensors in turn (SB3's SAC samples with it)."""

    def rsample(distribution, sample_shape=torch.Size()):
        return distribution.loc + distribution.scale * draws.pop(0)

    return rsample


def _queued_sample(actor, draws: list[torch.Tensor]):
    """Our actor's ``sample`` with the queued standard-normal tensors as its noise, in turn."""
    real_sample = type(actor).sample

    def sample(latent, noise=None):
        return real_sample(actor, latent, draws.pop(0))

    return sample


@pytest.mark.parametrize("ac", ["ddpg", "td3", "sac"])
def test_update_moves_every_network_as_stable_baselines3_does(ac, monkeypatch):
    reference, ours, pairs = _models(ac)
    initial_actor = [layer.weight.detach().clone() for layer in _linears(ours.actor)]
    rng = np.random.default_rng(1)
    for update in range(UPDATES):
        obs, action, reward, next_obs, terminated = (torch.from_numpy(x) for x in _minibatch(rng))
        samples = ReplayBufferSamples(obs, action, next_obs, terminated[:, None], reward[:, None])
        monkeypatch.setattr(reference.replay_buffer, "sample", lambda *args, s=samples, **kw: s)
        if ac == "sac":  # SB3 draws for the current states, then the next; ours in its own order
            draw_obs, draw_next = torch.randn(BATCH, 1), torch.randn(BATCH, 1)
            monkeypatch.setattr(torch.distributions.Normal, "rsample", _queued_rsample([draw_obs, draw_next]))
            monkeypatch.setattr(ours.actor, "sample", _queued_sample(ours.actor, [draw_next, draw_obs]))
        reference._n_updates = update
        torch.manual_seed(update)  # TD3's target smoothing draws the same noise on both sides
        reference.train(gradient_steps=1, batch_size=BATCH)
        torch.manual_seed(update)
        ours.update(PixelBatch(obs, action, reward, next_obs, terminated, reward))
        assert _gap(pairs) < TOLERANCE, f"{ac}: networks part after update {update + 1}"
    if ac == "sac":
        assert abs(float(reference.log_ent_coef.detach()) - float(ours.log_alpha.detach())) < 1e-6
    now = [layer.weight.detach() for layer in _linears(ours.actor)]
    moved = max(float((w - w0).abs().max()) for w, w0 in zip(now, initial_actor, strict=True))
    assert moved > 1e-3  # the updates did move the actor: the comparison is not between two idle copies
