"""TD3 (Fujimoto et al. 2018, Algorithm 1) on the critic-autoencoder: DDPG with its three repairs.

1. Clipped double Q-learning: two critics, each regressed to one target that bootstraps from the *smaller* of
   the two target critics, y = r + γ (1 − d) min_i Q′_i(φ′, ã′).
2. Target policy smoothing: ã′ = clip(μ′(φ′) + clip(ε, −c, c), −1, 1), ε ~ N(0, σ̃²), with σ̃ =
   ``agent.target_noise`` (0.2) and c = ``agent.target_noise_clip`` (0.5), in the normalised action units.
3. Delayed policy updates: the actor's step (on Q₁ only) and the τ target updates happen every
   ``agent.policy_delay`` (2) critic updates.

Exploration is additive noise around μ(φ) like DDPG's (``agent.noise``; SB3's TD3 has none by default and
takes its exploration from the uniform warm-up).
"""

from __future__ import annotations

import torch

from core.modelfree.learners.base import ActorUpdateResult, frozen
from core.modelfree.learners.ddpg import NoiseExploring
from core.modelfree.networks import TwinCritic


class TD3(NoiseExploring):
    """Twin critics, smoothed target actions, delayed actor and targets (module docstring)."""

    name = "td3"
    twin_critics = True
    twin_loss_weight = 1.0
    critic: TwinCritic

    @torch.no_grad()
    def bootstrap(self, next_latent: torch.Tensor) -> torch.Tensor:
        """min_i Q′_i(φ′, clip(μ′(φ′) + clip(ε, −c, c), −1, 1)) (repairs 1 and 2)."""
        cfg = self.agent_config
        action = self.target_actor(next_latent)
        clip = cfg.target_noise_clip
        noise = (torch.randn_like(action) * cfg.target_noise).clamp(-clip, clip)
        smoothed = (action + noise).clamp(-1.0, 1.0)
        return self.target_critic(next_latent, smoothed).min(dim=0).values

    def policy_step(
        self, latent: torch.Tensor, action: torch.Tensor, target: torch.Tensor
    ) -> ActorUpdateResult:
        """Every ``policy_delay``-th update: minimise −Q₁(φ, μ(φ)), then the τ target updates (repair 3)."""
        if self.updates % self.agent_config.policy_delay != 0:
            return ActorUpdateResult(loss=float("nan"))
        with frozen(self.critic):
            loss = -self.critic.q1(latent, self.actor(latent)).mean()
            self.actor_optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.actor_optimizer.step()
        self.update_targets()
        return ActorUpdateResult(loss=float(loss.detach()))
