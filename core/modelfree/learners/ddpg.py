"""The paper's two learners (Section 2.1): DDPG (Eq. 2) and off-policy CACLA (Eq. 3), on the
critic-autoencoder.

Both have one critic Q and a deterministic actor μ with target copies; the target bootstraps from
Q′(φ′, μ′(φ′)) (Eq. 1); exploration is noise around μ(φ) (``core.modelfree.noise``); after every actor step
the encoder, critic and actor targets move by τ (Algorithm 2, line 28).
"""

from __future__ import annotations

import numpy as np
import torch

from core.config import AgentConfig, NetConfig
from core.envs.spec import EnvSpec
from core.modelfree.learners.base import ActorUpdateResult, Learner, frozen
from core.modelfree.noise import make_noise, uniform_warmup


class NoiseExploring(Learner):
    """A deterministic actor explored by additive noise (DDPG, CACLA, TD3): Algorithm 2, line 20. During the
    uniform warm-up the noise perturbs the uniform action instead of the actor's, as SB3 does
    (``core.modelfree.noise``)."""

    def __init__(self, net: NetConfig, agent: AgentConfig, spec: EnvSpec) -> None:
        super().__init__(net, agent, spec)
        self.noise = make_noise(agent, spec.action_dim)

    def begin_episode(self) -> None:
        self.noise.reset()

    def explore(
        self, action: np.ndarray, latent: torch.Tensor, step: int, rng: np.random.Generator
    ) -> np.ndarray:
        warmup = uniform_warmup(self.agent_config, step, self.action_dim, rng)
        return self.noise.perturb(action if warmup is None else warmup, step, rng)

    def extra_state(self) -> dict:
        return {"noise": self.noise.state()}

    def load_extra_state(self, state: dict) -> None:
        self.noise.load_state(state.get("noise", []))


class DDPG(NoiseExploring):
    """DDPG (Eq. 2): minimise L = −(1/n) Σ_i Q(φ_i, μ(φ_i)) over θ^μ, ``ddpg_actor_passes`` times."""

    name = "ddpg"

    @torch.no_grad()
    def bootstrap(self, next_latent: torch.Tensor) -> torch.Tensor:
        """Q′(φ′, μ′(φ′)) (Eq. 1)."""
        return self.target_critic(next_latent, self.target_actor(next_latent))

    def policy_step(
        self, latent: torch.Tensor, action: torch.Tensor, target: torch.Tensor
    ) -> ActorUpdateResult:
        loss = torch.zeros(())
        with frozen(self.critic):
            for _ in range(self.agent_config.ddpg_actor_passes):
                loss = -self.critic(latent, self.actor(latent)).mean()
                self.actor_optimizer.zero_grad(set_to_none=True)
                loss.backward()
                self.actor_optimizer.step()
        self.update_targets()
        return ActorUpdateResult(loss=float(loss.detach()))


class CACLA(DDPG):
    """Off-policy CACLA (Eq. 3): regress μ(φ_t) toward a_t only where δ_t > 0.

    δ_t = y_t − Q(φ_t, μ(φ_t)) with y_t the Eq. 1 target from the target networks, exactly as the paper
    writes it. The positive set is computed once per minibatch (after the critic update), then the actor
    takes ``cacla_actor_passes`` Adam steps on the mean of ‖a_t − μ(φ_t)‖² over that set (released code: 15).
    """

    name = "cacla"

    def policy_step(
        self, latent: torch.Tensor, action: torch.Tensor, target: torch.Tensor
    ) -> ActorUpdateResult:
        positive = self.positive_mask(latent, target)
        fraction = float(positive.float().mean())
        if not bool(positive.any()):
            self.update_targets()
            return ActorUpdateResult(loss=0.0, positive_fraction=fraction)
        chosen_latent, chosen_action = latent[positive], action[positive]
        loss = torch.zeros(())
        for _ in range(self.agent_config.cacla_actor_passes):
            loss = (self.actor(chosen_latent) - chosen_action).pow(2).sum(dim=1).mean()
            self.actor_optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.actor_optimizer.step()
        self.update_targets()
        return ActorUpdateResult(loss=float(loss.detach()), positive_fraction=fraction)

    @torch.no_grad()
    def positive_mask(self, latent: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """δ_t > 0 with δ_t = y_t − Q(φ_t, μ(φ_t)) (Eq. 3)."""
        return (target - self.critic(latent, self.actor(latent))) > 0
