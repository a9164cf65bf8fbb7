"""SAC (Haarnoja et al. 2018, "Soft Actor-Critic Algorithms and Applications", Algorithm 1) with the learned
temperature, on the critic-autoencoder: for images, the SAC-AE recipe (Yarats et al. 2019), which is the
paper's Eq. 4 critic-autoencoder with a LayerNorm + tanh latent (``net.latent_activation = auto``) and its own
encoder τ (``agent.encoder_tau``).

* Policy: squashed Gaussian a = tanh(u), u ~ N(m(φ), σ(φ)²) (``SquashedGaussianActor``), on the detached
  latent.
* Critic target: y = r + γ (1 − d) [min_i Q′_i(φ′, a′) − α log π(a′ | φ′)], a′ ~ π(· | φ′).
* Actor: minimise E[α log π(a | φ) − min_i Q_i(φ, a)], a ~ π(· | φ) (reparameterised).
* Temperature: minimise −log α · (log π(a | φ) + H̄) with H̄ = ``agent.target_entropy`` (None: −dim A), so α
  rises while the policy's entropy is below H̄ and falls while above; α of the step is the one before it (SB3).
* Targets: encoder and critics move by τ after every update (no target actor in SAC).
* Exploration: a sample of π. Around a chosen action a* (the dual system's planner), the same Gaussian is
  re-centred on it: a = tanh(atanh(a*) + σ(φ) ε), which is exactly π's sample when a* = tanh(m(φ)).
  ε ~ N(0, I) i.i.d.; with ``agent.noise = pink``, ε is the next value of ``pink-noise-rl``'s pink process
  (a new sequence every episode, ``core.modelfree.noise.PinkNoise`` at σ = 1), as the package's
  ``PinkNoiseDist`` samples a = tanh(m + σ ε_pink). Acting only: the updates sample π i.i.d.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from core.config import AgentConfig, NetConfig
from core.envs.spec import EnvSpec
from core.modelfree.learners.base import ActorUpdateResult, Learner, frozen
from core.modelfree.networks import SquashedGaussianActor, TwinCritic
from core.modelfree.noise import PinkNoise, make_noise, uniform_warmup

ATANH_LIMIT = 1.0 - 1e-6
"""Chosen actions are clipped to ±this before atanh (a saturated plan stays finite)."""


class SAC(Learner):
    """Twin critics, squashed-Gaussian actor, learned temperature α (module docstring)."""

    name = "sac"
    twin_critics = True
    target_actor_kept = False
    critic: TwinCritic
    actor: SquashedGaussianActor

    def __init__(self, net: NetConfig, agent: AgentConfig, spec: EnvSpec) -> None:
        super().__init__(net, agent, spec)
        self.log_alpha = torch.nn.Parameter(torch.tensor(math.log(agent.alpha_init)))
        self.alpha_optimizer = torch.optim.Adam([self.log_alpha], lr=agent.actor_lr)
        self.target_entropy = (
            -float(spec.action_dim) if agent.target_entropy is None else float(agent.target_entropy)
        )
        self.pink: PinkNoise | None = None
        """The pink process of acting's ε (``agent.noise = pink``); None: i.i.d. N(0, I)."""
        if agent.noise == "pink":
            self.pink = make_noise(agent, spec.action_dim)  # type: ignore[assignment]

    @property
    def alpha(self) -> float:
        return float(self.log_alpha.detach().exp())

    def begin_episode(self) -> None:
        if self.pink is not None:
            self.pink.reset()

    def explore(
        self, action: np.ndarray, latent: torch.Tensor, step: int, rng: np.random.Generator
    ) -> np.ndarray:
        """tanh(atanh(a*) + σ(φ) ε) with ε from the agent's generator (i.i.d., or the pink process's next
        value): π's sample when a* is its mean."""
        warmup = uniform_warmup(self.agent_config, step, self.action_dim, rng)
        if warmup is not None:
            return warmup
        with torch.no_grad():
            _, log_std = self.actor.distribution(latent.reshape(1, -1))
        std = log_std[0].exp().numpy().astype(np.float64)
        centre = np.arctanh(np.clip(action.astype(np.float64), -ATANH_LIMIT, ATANH_LIMIT))
        eps = rng.normal(size=centre.shape) if self.pink is None else self.pink.sample(rng)
        return np.tanh(centre + std * eps).astype(np.float32)

    def extra_state(self) -> dict:
        return {} if self.pink is None else {"noise": self.pink.state()}

    def load_extra_state(self, state: dict) -> None:
        if self.pink is not None:
            self.pink.load_state(state.get("noise", []))

    @torch.no_grad()
    def bootstrap(self, next_latent: torch.Tensor) -> torch.Tensor:
        """min_i Q′_i(φ′, a′) − α log π(a′ | φ′), a′ ~ π(· | φ′): the soft value."""
        action, log_prob = self.actor.sample(next_latent)
        return self.target_critic(next_latent, action).min(dim=0).values - self.alpha * log_prob

    @torch.no_grad()
    def target_action(self, latent: torch.Tensor) -> torch.Tensor:
        return self.actor(latent)

    def policy_step(
        self, latent: torch.Tensor, action: torch.Tensor, target: torch.Tensor
    ) -> ActorUpdateResult:
        """The actor's step at the current α, then α's step, then the τ targets."""
        alpha = self.alpha
        with frozen(self.critic):
            sampled, log_prob = self.actor.sample(latent)
            q = self.critic(latent, sampled).min(dim=0).values
            loss = (alpha * log_prob - q).mean()
            self.actor_optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.actor_optimizer.step()
        alpha_loss = -(self.log_alpha * (log_prob.detach() + self.target_entropy)).mean()
        self.alpha_optimizer.zero_grad(set_to_none=True)
        alpha_loss.backward()
        self.alpha_optimizer.step()
        self.update_targets()
        return ActorUpdateResult(
            loss=float(loss.detach()),
            extra={"losses/alpha": alpha, "losses/entropy": float(-log_prob.detach().mean())},
        )

    def optimizers(self) -> dict:
        return {**super().optimizers(), "alpha_optimizer": self.alpha_optimizer}
