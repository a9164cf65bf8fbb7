"""The model-free learner of Section 2.1: critic-autoencoder (Eq. 4 with the TD target of Eq. 1) and an
actor update strategy — DDPG (Eq. 2) or off-policy CACLA (Eq. 3) — plus τ target updates.

One minibatch update (Algorithm 2, lines 26-28) is :meth:`ActorCritic.update_pixels`:

1. ``y = r + γ (1 − terminated) Q′(f′(s′), μ′(f′(s′)))`` with the target encoder, critic and actor (Eq. 1).
   Truncation at the step limit is not termination: it bootstraps.
2. ``critic_passes`` Adam steps on ``λ_rec · L_rec + λ_Q · L_Q`` over the same minibatch (Eq. 4), updating
   encoder ω, decoder ω̃ and critic θ^Q together. L_rec is the mean squared pixel (or scaled vector) error
   (Keras' MSE in the released code; the paper writes the squared norm, which only rescales λ_rec), L_Q the
   mean of Eq. 1.
3. ``actor_passes`` steps of the actor strategy on φ = f(s) from the last critic pass (detached: the actor
   never trains the encoder; reusing that forward pass saves one encoder evaluation per update).
4. ``θ′ ← τ θ + (1 − τ) θ′`` for encoder, critic and actor, one fused ``torch._foreach_lerp_``.

:meth:`ActorCritic.update_latents` is the same update on latent transitions (critic head + actor only,
the encoder is not involved), which I2A runs on minibatches from B_latent (Algorithm 3, lines 35-36).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass

import torch
from torch import nn

from core.config import AgentConfig, NetConfig
from core.envs.spec import EnvSpec
from core.modelfree.networks import ActionBounds, Actor, Critic, PolicyNetwork, make_decoder, make_encoder
from core.modelfree.replay import LatentBatch, PixelBatch


@dataclass
class ActorUpdateResult:
    """What an actor strategy reports for one minibatch: the last pass's loss and a diagnostic."""

    loss: float
    positive_fraction: float = float("nan")


class DDPGActorUpdate:
    """Eq. 2: minimise L = −(1/n) Σ_i Q(φ_i, μ(φ_i)); gradients reach θ^μ only."""

    name = "ddpg"

    def __init__(self, passes: int) -> None:
        self.passes = passes

    def __call__(
        self, learner: ActorCritic, latent: torch.Tensor, action: torch.Tensor, target: torch.Tensor
    ) -> ActorUpdateResult:
        loss = torch.zeros(())
        with _frozen(learner.critic):
            for _ in range(self.passes):
                loss = -learner.critic(latent, learner.actor(latent)).mean()
                learner.actor_optimizer.zero_grad(set_to_none=True)
                loss.backward()
                learner.actor_optimizer.step()
        return ActorUpdateResult(loss=float(loss.detach()))


class CACLAActorUpdate:
    """Eq. 3, off-policy CACLA: regress μ(φ_t) toward a_t only where δ_t > 0.

    δ_t = y_t − Q(φ_t, μ(φ_t)) with y_t the Eq. 1 target from the target networks, exactly as the paper
    writes it. The positive set is computed once per minibatch (after the critic update), then the actor
    takes ``passes`` Adam steps on the mean of ‖a_t − μ(φ_t)‖² over that set (the released code: 15).
    """

    name = "cacla"

    def __init__(self, passes: int) -> None:
        self.passes = passes

    def __call__(
        self, learner: ActorCritic, latent: torch.Tensor, action: torch.Tensor, target: torch.Tensor
    ) -> ActorUpdateResult:
        positive = self.positive_mask(learner, latent, target)
        fraction = float(positive.float().mean())
        if not bool(positive.any()):
            return ActorUpdateResult(loss=0.0, positive_fraction=fraction)
        chosen_latent, chosen_action = latent[positive], action[positive]
        loss = torch.zeros(())
        for _ in range(self.passes):
            loss = (learner.actor(chosen_latent) - chosen_action).pow(2).sum(dim=1).mean()
            learner.actor_optimizer.zero_grad(set_to_none=True)
            loss.backward()
            learner.actor_optimizer.step()
        return ActorUpdateResult(loss=float(loss.detach()), positive_fraction=fraction)

    @staticmethod
    def positive_mask(learner: ActorCritic, latent: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """δ_t > 0 with δ_t = y_t − Q(φ_t, μ(φ_t)) (Eq. 3)."""
        with torch.no_grad():
            delta = target - learner.critic(latent, learner.actor(latent))
        return delta > 0


ActorUpdate = Callable[["ActorCritic", torch.Tensor, torch.Tensor, torch.Tensor], ActorUpdateResult]

ACTOR_UPDATES: dict[str, Callable[[AgentConfig], ActorUpdate]] = {
    "ddpg": lambda cfg: DDPGActorUpdate(cfg.ddpg_actor_passes),
    "cacla": lambda cfg: CACLAActorUpdate(cfg.cacla_actor_passes),
}
"""Actor-update strategies by name (``AgentConfig.ac``)."""


class _frozen:
    """Context manager: no parameter gradients for ``module`` (the DDPG actor step leaves θ^Q alone)."""

    def __init__(self, module: nn.Module) -> None:
        self.params = list(module.parameters())

    def __enter__(self) -> None:
        for param in self.params:
            param.requires_grad_(False)

    def __exit__(self, *exc: object) -> None:
        for param in self.params:
            param.requires_grad_(True)


def soft_update(target: nn.Module, online: nn.Module, tau: float) -> None:
    """θ′ ← τ θ + (1 − τ) θ′ for every parameter, as one fused ``lerp_`` (Algorithm 2, line 28)."""
    target_params = [p.data for p in target.parameters()]
    online_params = [p.data for p in online.parameters()]
    torch._foreach_lerp_(target_params, online_params, tau)


class ActorCritic(nn.Module):
    """Encoder, decoder, critic, actor, their target copies (encoder, critic, actor) and optimisers."""

    def __init__(
        self,
        net: NetConfig,
        agent: AgentConfig,
        spec: EnvSpec,
    ) -> None:
        super().__init__()
        if agent.ac not in ACTOR_UPDATES:
            raise ValueError(f"unknown actor update {agent.ac!r} (choose from {', '.join(ACTOR_UPDATES)})")
        self.net_config, self.agent_config = net, agent
        self.action_dim = action_dim = spec.action_dim
        self.encoder = make_encoder(net, spec)
        self.decoder = make_decoder(net, self.encoder, spec)
        self.critic = Critic(net, action_dim)
        self.actor = Actor(net, action_dim)
        self.bounds = ActionBounds(*(torch.from_numpy(b) for b in spec.bounds()))
        self.target_encoder = copy.deepcopy(self.encoder).requires_grad_(False)
        self.target_critic = copy.deepcopy(self.critic).requires_grad_(False)
        self.target_actor = copy.deepcopy(self.actor).requires_grad_(False)
        self.critic_optimizer = torch.optim.Adam(
            [*self.encoder.parameters(), *self.decoder.parameters(), *self.critic.parameters()],
            lr=agent.critic_lr,
        )
        self.actor_optimizer = torch.optim.Adam(self.actor.parameters(), lr=agent.actor_lr)
        self.actor_update: ActorUpdate = ACTOR_UPDATES[agent.ac](agent)

    # -- acting ----------------------------------------------------------------------------------
    @torch.no_grad()
    def encode(self, obs: torch.Tensor) -> torch.Tensor:
        """φ = f_ω(s) for stored observations ``[N, *obs_shape]`` (uint8 images or vectors)."""
        return self.encoder(self.encoder.prepare(obs))

    @torch.no_grad()
    def policy(self, latent: torch.Tensor) -> torch.Tensor:
        """μ(φ) without exploration noise."""
        return self.actor(latent)

    def policy_network(self) -> PolicyNetwork:
        """Encoder + actor + the env's action bounds as one module (shares parameters with this learner)."""
        return PolicyNetwork(self.encoder, self.actor, self.bounds)

    # -- learning --------------------------------------------------------------------------------
    @torch.no_grad()
    def td_target(
        self, reward: torch.Tensor, next_latent_target: torch.Tensor, terminated: torch.Tensor
    ) -> torch.Tensor:
        """Eq. 1 target y = r + γ (1 − terminated) Q′(φ′, μ′(φ′)), φ′ from the target encoder."""
        next_q = self.target_critic(next_latent_target, self.target_actor(next_latent_target))
        return reward + self.agent_config.gamma * (1.0 - terminated) * next_q

    def update_pixels(self, batch: PixelBatch) -> dict[str, float]:
        """One minibatch update from B_pixel: Eq. 4 (critic_passes), the actor strategy, target update."""
        cfg = self.agent_config
        obs = self.encoder.prepare(batch.obs)
        with torch.no_grad():
            target = self.td_target(
                batch.reward, self.target_encoder(self.encoder.prepare(batch.next_obs)), batch.terminated
            )
        rec_loss = q_loss = torch.zeros(())
        latent = torch.zeros(())
        for _ in range(cfg.critic_passes):
            latent = self.encoder(obs)
            rec_loss = (self.decoder(latent) - obs).pow(2).mean()
            q_loss = (target - self.critic(latent, batch.action)).pow(2).mean()
            loss = cfg.lambda_rec * rec_loss + cfg.lambda_q * q_loss
            self.critic_optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.critic_optimizer.step()
        # The actor reads φ of the last critic pass (before its Adam step): one encoder forward fewer.
        actor = self.actor_update(self, latent.detach(), batch.action, target)
        self.update_targets()
        return {
            "losses/critic": float(q_loss.detach()),
            "losses/rec": float(rec_loss.detach()),
            "losses/actor": actor.loss,
            "losses/td_target_mean": float(target.mean()),
            **(
                {}
                if actor.positive_fraction != actor.positive_fraction
                else {"losses/cacla_positive_fraction": actor.positive_fraction}
            ),
        }

    def update_latents(self, batch: LatentBatch) -> dict[str, float]:
        """Critic head (Eq. 1) and actor (Eq. 2/3) on latent transitions, encoder untouched (Alg. 3, 35-36).

        The next-state value uses the target critic and actor on the stored φ′ directly.
        """
        cfg = self.agent_config
        target = self.td_target(batch.reward, batch.next_latent, batch.done)
        q_loss = torch.zeros(())
        critic_params = list(self.critic.parameters())
        for _ in range(cfg.critic_passes):
            q_loss = (target - self.critic(batch.latent, batch.action)).pow(2).mean()
            grads = torch.autograd.grad(cfg.lambda_q * q_loss, critic_params)
            for param, grad in zip(critic_params, grads, strict=True):
                param.grad = grad
            self._step_critic_only()
        actor = self.actor_update(self, batch.latent, batch.action, target)
        return {"losses/latent_critic": float(q_loss.detach()), "losses/latent_actor": actor.loss}

    def _step_critic_only(self) -> None:
        """Adam step of the critic-autoencoder optimiser with only the critic head's gradients set."""
        for param in [*self.encoder.parameters(), *self.decoder.parameters()]:
            param.grad = None
        self.critic_optimizer.step()
        self.critic_optimizer.zero_grad(set_to_none=True)

    def update_targets(self) -> None:
        """τ update of the target encoder, critic and actor (Algorithm 2, line 28)."""
        tau = self.agent_config.tau
        soft_update(self.target_encoder, self.encoder, tau)
        soft_update(self.target_critic, self.critic, tau)
        soft_update(self.target_actor, self.actor, tau)

    # -- persistence -----------------------------------------------------------------------------
    def full_state_dict(self) -> dict:
        """Networks (online + target) and both optimisers' states."""
        return {
            "modules": self.state_dict(),
            "critic_optimizer": self.critic_optimizer.state_dict(),
            "actor_optimizer": self.actor_optimizer.state_dict(),
        }

    def load_full_state_dict(self, state: dict) -> None:
        self.load_state_dict(state["modules"])
        self.critic_optimizer.load_state_dict(state["critic_optimizer"])
        self.actor_optimizer.load_state_dict(state["actor_optimizer"])
