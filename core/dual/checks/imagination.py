"""Check: imagination adds data a critic can use, and nothing when the model cannot predict (Alg. 3 lines
13-21, 35; ``dual.imagination``: `core.dual.readings.Imagination`).

Purpose (Section 3): imagined transitions are more training data for the critic and the actor. They help
when the model is right and should not hurt when it is not. The check is a small latent MDP with a known
optimum of the critic: φ ∈ [−1, 1]², a ∈ [−1, 1]², φ′ = clip(φ + 0.2 a), reward −0.1·‖φ′ − g‖², terminal
(with reward 0) once ‖φ′ − g‖ < 0.15, γ = 0.9, and a fixed policy μ(φ) = tanh(2(g − φ)). A critic Q(φ, a)
(two hidden layers of 32) learns Q^μ by TD (Eq. 1 with μ in the target, a target copy at τ = 0.05) from 200
real transitions (uniform φ and a), for 1000 minibatch steps of 64 real transitions, in three versions:

- real only;
- with learn-time imagination (`core.dual.imagination.imagine`, the function the agents call) from the true
  model: each step the minibatch's states are rolled out 3 steps under μ, transitions terminal where the
  model says so (never without `Imagination.termination`, as a bank without the head gives);
- the same from the no-change model (φ̂′ = φ, r̂ = 0, never terminal).

Each imagined transition is kept with the profile's gate (`Imagination.gate`): with ``no_change_ratio``
the probability `core.dual.reliability.share_from_ratio` of the model's Eq. 8 error / the no-change
predictor's on 500 held-out real transitions (0 for the true model, 1 for the no-change model); with
``none`` always. Figures: the critic's mean squared error against the true Q^μ (by rollout) on the held-out
transitions, averaged over three seeds. With the paper's act-time source (B_latent) the
check still imagines at learn time: what it measures is the gate and the terminal rule, not the storage.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from core.config import DualConfig
from core.dual.imagination import imagine
from core.dual.model_bank import ModelPrediction
from core.dual.readings import resolve
from core.dual.reliability import share_from_ratio

GOAL = np.array([0.5, 0.3])
GAMMA, RADIUS, STEP = 0.9, 0.15, 0.2


def _true_step(phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
    nxt = (phi + STEP * action.clamp(-1.0, 1.0)).clamp(-1.0, 1.0)
    distance = (nxt - torch.as_tensor(GOAL, dtype=nxt.dtype)).norm(dim=-1)
    done = (distance < RADIUS).to(nxt.dtype)
    return ModelPrediction(next_latent=nxt, reward=-0.1 * distance**2 * (1.0 - done), done=done)


def policy(phi: torch.Tensor) -> torch.Tensor:
    """μ(φ) = tanh(2 (g − φ))."""
    return torch.tanh(2.0 * (torch.as_tensor(GOAL, dtype=phi.dtype) - phi))


class _Model:
    """An `ImaginationModel` with one region: the true toy or the no-change predictor, and a fixed share."""

    def __init__(self, true: bool, share: float, termination: bool = True) -> None:
        self.true, self._share, self.termination = true, share, termination

    def locate(self, phi: torch.Tensor) -> np.ndarray:
        return np.zeros(phi.shape[0], dtype=np.int64)

    def proceed(self, regions: np.ndarray) -> np.ndarray:
        return np.ones(regions.shape[0], dtype=bool)

    def predict(self, regions: np.ndarray, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        if self.true:
            step = _true_step(phi, action)
            if not self.termination:  # a bank without a termination head: imagined steps are never terminal
                step = ModelPrediction(step.next_latent, step.reward, torch.zeros_like(step.done))
            return step
        zeros = torch.zeros(phi.shape[0])
        return ModelPrediction(next_latent=phi.clone(), reward=zeros, done=zeros)

    def share(self, regions: np.ndarray) -> np.ndarray:
        return np.full(regions.shape[0], self._share)


def true_q(phi: torch.Tensor, action: torch.Tensor, horizon: int = 60) -> torch.Tensor:
    """Q^μ(φ, a) by rolling the toy out under μ after the first action."""
    total = torch.zeros(phi.shape[0])
    alive = torch.ones(phi.shape[0])
    discount = 1.0
    current, act = phi, action
    for _ in range(horizon):
        step = _true_step(current, act)
        total += alive * discount * step.reward
        alive = alive * (1.0 - step.done)
        discount *= GAMMA
        current = step.next_latent
        act = policy(current)
    return total


def _ratio(true: bool, phi: torch.Tensor, action: torch.Tensor, norm: str) -> float:
    """Eq. 8 error of the model / of "nothing changes" on held-out real transitions."""
    real = _true_step(phi, action)
    predicted = _Model(true, 1.0).predict(np.zeros(0), phi, action)

    def error(nxt: torch.Tensor, reward: torch.Tensor) -> torch.Tensor:
        d_latent, d_reward = nxt - real.next_latent, reward - real.reward
        if norm == "squared":
            return (d_latent**2).sum(-1) + d_reward**2
        return d_latent.norm(dim=-1) + d_reward.abs()

    model = error(predicted.next_latent, predicted.reward).mean()
    no_change = error(phi, torch.zeros_like(real.reward)).mean()
    return float(model / no_change)


def critic_error(dual: DualConfig, model: str, seed: int, updates: int = 1000, real: int = 200) -> float:
    """Held-out MSE of a critic trained on real transitions and the imagination of ``model``."""
    torch.manual_seed(seed)
    g = torch.Generator().manual_seed(seed)
    rng = np.random.default_rng(seed)
    imagine_rng = np.random.default_rng(seed + 1)  # its own stream: every version sees the same real batches
    phi = torch.rand(real, 2, generator=g) * 2 - 1
    action = torch.rand(real, 2, generator=g) * 2 - 1
    outcome = _true_step(phi, action)
    held_phi = torch.rand(500, 2, generator=g) * 2 - 1
    held_action = torch.rand(500, 2, generator=g) * 2 - 1
    held_q = true_q(held_phi, held_action)
    imagination = None
    if model != "none":
        true = model == "true"
        share = 1.0
        read = resolve(dual)
        if read.imagination.gate == "no_change_ratio":
            share = float(share_from_ratio(_ratio(true, held_phi, held_action, read.reliability.error_norm),
                                           dual.imagination_max_ratio))
        imagination = _Model(true, share, termination=read.imagination.termination)
    critic = nn.Sequential(nn.Linear(4, 32), nn.ReLU(), nn.Linear(32, 32), nn.ReLU(), nn.Linear(32, 1))
    target = nn.Sequential(nn.Linear(4, 32), nn.ReLU(), nn.Linear(32, 32), nn.ReLU(), nn.Linear(32, 1))
    target.load_state_dict(critic.state_dict())
    optimiser = torch.optim.Adam(critic.parameters(), lr=1e-3)
    for _ in range(updates):
        rows = torch.from_numpy(rng.integers(0, real, size=64))
        s, a, r = phi[rows], action[rows], outcome.reward[rows]
        s2, d = outcome.next_latent[rows], outcome.done[rows]
        if imagination is not None:
            batch = imagine(s, imagination, policy, 3, imagine_rng, 64)
            if batch is not None:
                s, a = torch.cat([s, batch.latent]), torch.cat([a, batch.action])
                r = torch.cat([r, batch.reward])
                s2, d = torch.cat([s2, batch.next_latent]), torch.cat([d, batch.done])
        with torch.no_grad():
            y = r + GAMMA * (1.0 - d) * target(torch.cat([s2, policy(s2)], -1)).squeeze(-1)
        loss = (critic(torch.cat([s, a], -1)).squeeze(-1) - y).pow(2).mean()
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        with torch.no_grad():
            for p, q in zip(target.parameters(), critic.parameters(), strict=True):
                p.lerp_(q, 0.05)
    with torch.no_grad():
        predicted = critic(torch.cat([held_phi, held_action], -1)).squeeze(-1)
    return float((predicted - held_q).pow(2).mean())


def imagination_check(dual: DualConfig, seeds: int = 3, updates: int = 1000) -> dict[str, float]:
    """The JSON figures: held-out critic errors of real-only, true-model and no-change-model training."""
    names = {"none": "critic_error_real_only", "true": "critic_error_true_model",
             "no_change": "critic_error_no_change_model"}
    return {
        name: round(float(np.mean([critic_error(dual, model, seed, updates) for seed in range(seeds)])), 5)
        for model, name in names.items()
    }
