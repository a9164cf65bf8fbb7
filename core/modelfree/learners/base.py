"""What every learner shares: the critic-autoencoder of Section 2.1 (Eq. 4 with the TD target of Eq. 1), its
target networks, and the two minibatch updates the agents call.

A learner is a component the agents *hold* (``core.modelfree.agent``, ``core.dual.im2c``, ``core.dual.i2a``):
encoder f_ω, decoder g_ω̃, critic(s), actor, target copies and optimisers. The algorithm-specific parts are
three methods each learner file writes out in full (``ddpg.py``, ``td3.py``, ``sac.py``):

* ``bootstrap(φ′)`` — the value the TD target bootstraps from (DDPG: Q′(φ′, μ′(φ′)); TD3: the smaller of two
  target critics at a smoothed target action; SAC: the soft value);
* ``policy_step(φ, a, y)`` — the actor's step after the critic's (TD3: delayed; SAC: with the temperature's);
* ``explore(a, φ, step, rng)`` — the executed action around a chosen one (noise, or SAC's sampling).

One update, :meth:`Learner.update`, for every agent: one minibatch from the pixel replay B (Algorithm 2,
lines 26-28) and, for I2A, one latent minibatch of imagined transitions (Algorithm 3, lines 34-37):

1. ``y = r + γ (1 − terminated) · bootstrap(f′(s′))`` with the target encoder (Eq. 1); an imagined row's
   target bootstraps from its predicted φ̂′ (and its predicted ``done``). Truncation at the step limit is not
   termination: it bootstraps.
2. ``critic_passes`` Adam steps on ``λ_rec · L_rec + λ_Q · L_Q`` (Eq. 4) over the pixel minibatch, updating
   encoder ω, decoder ω̃ and critic θ^Q together. L_rec is the mean squared pixel (or scaled vector) error
   (Keras' MSE in the released code; the paper writes the squared norm, which only rescales λ_rec), L_Q the
   mean of Eq. 1 (twin critics: ``twin_loss_weight`` · Σ_i of each critic's mean, as SB3). Without a learned
   encoder (``net.encoder = none``) only the critic steps. With imagined rows, L_Q splits in two: line 34's
   value term of the encoder, on the pixel rows through a frozen copy of the critic, and line 35's critic
   term, on the pixel rows' detached φ and the imagined rows together. The two touch disjoint parameters, so
   they are one backward pass and one Adam step (Adam is per parameter: identical to two separate steps).
3. the learner's ``policy_step`` (line 36; τ target updates inside it, line 37: TD3 delays them) on φ = f(s)
   of the last critic pass (detached: the actor never trains the encoder), with the imagined rows' φ when
   there are any. Which φ: the one the critic's loss was computed on, before the pass's Adam step; reusing
   that forward pass saves one encoder evaluation per update (docs/model-free.md, "One update path").

``value_expansion`` (MVE, ``core.dual.baselines``) replaces ``bootstrap`` in the target when set.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.func import functional_call

from core.config import AgentConfig, NetConfig
from core.envs.spec import EnvSpec
from core.modelfree.networks import (
    ActionBounds,
    Actor,
    Critic,
    PolicyNetwork,
    TwinCritic,
    head_sizes,
    make_actor,
    make_decoder,
    make_encoder,
)
from core.modelfree.replay import LatentBatch, PixelBatch

ValueExpansionFn = Callable[["Learner", torch.Tensor], torch.Tensor]
"""``(learner, φ′) -> V(φ′)``: a model-based replacement of the learner's bootstrap value (MVE)."""


@dataclass
class ActorUpdateResult:
    """What a policy step reports for one minibatch: the last pass's loss and a diagnostic."""

    loss: float
    positive_fraction: float = float("nan")
    extra: dict[str, float] | None = None


class frozen:
    """Context manager: no parameter gradients for ``module`` (the actor step leaves θ^Q alone)."""

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
    if target_params:
        torch._foreach_lerp_(target_params, online_params, tau)


def smaller_twin(q: torch.Tensor) -> torch.Tensor:
    """A critic's output ``[N]`` or twins' ``[2, N]`` read as one value per row: the smaller twin."""
    return q if q.dim() == 1 else q.min(dim=0).values


def td_loss(q: torch.Tensor, target: torch.Tensor, twin_weight: float = 0.5) -> torch.Tensor:
    """Mean squared TD error of Eq. 1: ``q`` ``[N]`` (one critic) or ``[2, N]`` (twins: ``twin_weight`` · Σ_i
    mean_i, the learner's ``twin_loss_weight``)."""
    if q.dim() == 1:
        return (target - q).pow(2).mean()
    return twin_weight * (target - q).pow(2).mean(dim=1).sum()


class Learner(nn.Module):
    """Encoder, decoder, critic(s), actor, their target copies and optimisers; the shared updates."""

    name = "learner"
    twin_critics = False
    """Two critics (TD3, SAC) or one (DDPG, CACLA)."""
    target_actor_kept = True
    """Whether a target actor μ′ exists (not in SAC)."""
    twin_loss_weight = 0.5
    """Twin critics' loss: this weight times the sum of their mean squared TD errors (SAC: ½, as SB3's SAC;
    TD3: 1, as Fujimoto's reference code and SB3's TD3). Under Adam it matters only through ε."""

    def __init__(self, net: NetConfig, agent: AgentConfig, spec: EnvSpec) -> None:
        super().__init__()
        self.net_config, self.agent_config = net, agent
        self.action_dim = action_dim = spec.action_dim
        self.encoder = make_encoder(net, spec, self.name)
        self.latent_dim = latent_dim = self.encoder.latent_dim
        self.decoder = make_decoder(net, self.encoder, spec)
        _, critic_hidden = head_sizes(net, spec)
        critic_cls = TwinCritic if self.twin_critics else Critic
        self.critic: nn.Module = critic_cls(latent_dim, action_dim, critic_hidden)
        self.actor: Actor = make_actor(net, spec, self.name, latent_dim)
        self.bounds = ActionBounds(*(torch.from_numpy(b) for b in spec.bounds()))
        self.target_encoder = copy.deepcopy(self.encoder).requires_grad_(False)
        self.target_critic = copy.deepcopy(self.critic).requires_grad_(False)
        if self.target_actor_kept:
            self.target_actor = copy.deepcopy(self.actor).requires_grad_(False)
        decoder_params = [] if self.decoder is None else list(self.decoder.parameters())
        self.critic_optimizer = torch.optim.Adam(
            [*self.encoder.parameters(), *decoder_params, *self.critic.parameters()], lr=agent.critic_lr
        )
        self.actor_optimizer = torch.optim.Adam(self.actor.parameters(), lr=agent.actor_lr)
        self.updates = 0
        """Minibatch updates made (TD3's delay counts them)."""
        self.value_expansion: ValueExpansionFn | None = None

    # -- acting ----------------------------------------------------------------------------------
    @torch.no_grad()
    def encode(self, obs: torch.Tensor) -> torch.Tensor:
        """φ = f_ω(s) for stored observations ``[N, *obs_shape]`` (uint8 images or vectors)."""
        return self.encoder(self.encoder.prepare(obs))

    @torch.no_grad()
    def policy(self, latent: torch.Tensor) -> torch.Tensor:
        """The deterministic action μ(φ) (SAC: tanh of the mean) without exploration."""
        return self.actor(latent)

    def policy_network(self) -> PolicyNetwork:
        """Encoder + actor + the env's action bounds as one module (shares parameters with this learner)."""
        return PolicyNetwork(self.encoder, self.actor, self.bounds)

    def policy_state(self) -> dict[str, dict[str, torch.Tensor]]:
        """The deployable policy's state dicts (``core.runs.policy`` rebuilds it from the run's config)."""
        return {
            "encoder": self.encoder.state_dict(),
            "actor": self.actor.state_dict(),
            "bounds": self.bounds.state_dict(),
        }

    def begin_episode(self) -> None:
        """A training episode starts (temporally correlated noise resets here)."""

    def explore(
        self, action: np.ndarray, latent: torch.Tensor, step: int, rng: np.random.Generator
    ) -> np.ndarray:
        """The executed action around ``action`` (Algorithm 2, line 20); each learner writes its own."""
        raise NotImplementedError

    # -- learning --------------------------------------------------------------------------------
    @torch.no_grad()
    def bootstrap(self, next_latent: torch.Tensor) -> torch.Tensor:
        """V(φ′) of the TD target; each learner writes its own."""
        raise NotImplementedError

    def policy_step(
        self, latent: torch.Tensor, action: torch.Tensor, target: torch.Tensor
    ) -> ActorUpdateResult:
        """The actor's step (and target updates) after the critic's; each learner writes its own."""
        raise NotImplementedError

    @torch.no_grad()
    def td_target(
        self, reward: torch.Tensor, next_latent_target: torch.Tensor, terminated: torch.Tensor
    ) -> torch.Tensor:
        """Eq. 1 target y = r + γ (1 − terminated) V(φ′), φ′ from the target encoder."""
        if self.value_expansion is None:
            value = self.bootstrap(next_latent_target)
        else:
            value = self.value_expansion(self, next_latent_target)
        return reward + self.agent_config.gamma * (1.0 - terminated) * value

    @torch.no_grad()
    def target_action(self, latent: torch.Tensor) -> torch.Tensor:
        """The action the target policy takes at φ (MVE's imagined steps): μ′(φ), or SAC's tanh(mean)."""
        return self.target_actor(latent)

    def update(self, pixel: PixelBatch, latent: LatentBatch | None = None) -> dict[str, float]:
        """One update on a pixel minibatch and, for I2A, a latent minibatch of imagined transitions: Algorithm
        2 lines 26-28 (``latent`` None) and Algorithm 3 lines 34-37 (module docstring).

        Without imagined rows the encoder's value term and the critic's are one term, L_Q(f(s)), one critic
        pass. With them the encoder's value term reads the pixel rows through a frozen copy of the critic
        (line 34) and the critic's reads the pixel rows' detached φ and the imagined rows together (line 35);
        the sum has the same gradients as the one term when there are no imagined rows. The policy step reads
        φ of the last critic pass, before its Adam step (docs/model-free.md, "One update path"): one encoder
        forward fewer, and the φ the critic's loss was computed on."""
        cfg = self.agent_config
        self.updates += 1
        obs = self.encoder.prepare(pixel.obs)
        with torch.no_grad():
            next_phi = self.target_encoder(self.encoder.prepare(pixel.next_obs))
            y_pixel = self.td_target(pixel.reward, next_phi, pixel.terminated)
            if latent is not None:
                y_all = torch.cat([y_pixel, self.td_target(latent.reward, latent.next_latent, latent.done)])
                action_all = torch.cat([pixel.action, latent.action])
        rec_loss = q_encoder = q_critic = phi = torch.zeros(())
        for _ in range(cfg.critic_passes):
            phi = self.encoder(obs)
            if self.decoder is not None:
                rec_loss = (self.decoder(phi) - obs).pow(2).mean()
            if latent is None:
                q_critic = td_loss(self.critic(phi, pixel.action), y_pixel, self.twin_loss_weight)
                loss = cfg.lambda_q * q_critic
            else:
                frozen_critic = {name: p.detach() for name, p in self.critic.named_parameters()}
                q_frozen = functional_call(self.critic, frozen_critic, (phi, pixel.action))
                q_encoder = td_loss(q_frozen, y_pixel, self.twin_loss_weight)
                phi_all = torch.cat([phi.detach(), latent.latent])
                q_critic = td_loss(self.critic(phi_all, action_all), y_all, self.twin_loss_weight)
                loss = cfg.lambda_q * q_encoder + cfg.lambda_q * q_critic
            if self.decoder is not None:
                loss = cfg.lambda_rec * rec_loss + loss
            self.critic_optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.critic_optimizer.step()
        if latent is None:
            actor = self.policy_step(phi.detach(), pixel.action, y_pixel)
        else:
            actor = self.policy_step(torch.cat([phi.detach(), latent.latent]), action_all, y_all)
        out = {"losses/critic": float(q_critic.detach())}
        if latent is not None:
            out["losses/critic_encoder"] = float(q_encoder.detach())
        return {
            **out,
            "losses/rec": float(rec_loss.detach()),
            **_actor_loss(actor),
            "losses/td_target_mean": float(y_pixel.mean()),
            **_actor_extras(actor),
        }

    def update_targets(self) -> None:
        """τ update of the target encoder, critic and (where it exists) actor (Algorithm 2, line 28)."""
        cfg = self.agent_config
        tau = cfg.tau
        soft_update(self.target_encoder, self.encoder, tau if cfg.encoder_tau is None else cfg.encoder_tau)
        soft_update(self.target_critic, self.critic, tau)
        if self.target_actor_kept:
            soft_update(self.target_actor, self.actor, tau)

    @torch.no_grad()
    def q_value(self, latent: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """The online critic's Q(φ, a) (twins: the smaller), ``[N]``."""
        return smaller_twin(self.critic(latent, action))

    @torch.no_grad()
    def value_of(self, latent: torch.Tensor) -> torch.Tensor:
        """The critic's value of the policy's deterministic action, Q(φ, μ(φ)) (twins: the smaller), ``[N]``:
        the start-state value the trainer logs beside the discounted return actually earned."""
        return self.q_value(latent, self.actor(latent))

    def value_and_gradient(self, latent: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """`value_of` ``[N]`` and its gradient w.r.t. the latent ``[N, latent]``, through the critic and the
        deterministic action μ(φ) alike; the parameters' ``.grad`` stay untouched."""
        with torch.enable_grad():
            phi = latent.detach().requires_grad_(True)
            value = smaller_twin(self.critic(phi, self.actor(phi)))
            (grad,) = torch.autograd.grad(value.sum(), phi)
        return value.detach(), grad

    # -- persistence -----------------------------------------------------------------------------
    def optimizers(self) -> dict[str, Any]:
        """The optimisers by name (SAC adds its temperature's)."""
        return {"critic_optimizer": self.critic_optimizer, "actor_optimizer": self.actor_optimizer}

    def full_state_dict(self) -> dict:
        """Networks (online + target), the optimisers' states, the update count and the noise's state."""
        state: dict[str, Any] = {"modules": self.state_dict(), "updates": self.updates}
        state.update({name: optimizer.state_dict() for name, optimizer in self.optimizers().items()})
        state.update(self.extra_state())
        return state

    def load_full_state_dict(self, state: dict) -> None:
        self.load_state_dict(state["modules"])
        for name, optimizer in self.optimizers().items():
            optimizer.load_state_dict(state[name])
        self.updates = int(state.get("updates", 0))
        self.load_extra_state(state)

    def extra_state(self) -> dict[str, Any]:
        """What else a learner must save to resume exactly (exploration noise)."""
        return {}

    def load_extra_state(self, state: dict[str, Any]) -> None:
        return None


def _actor_loss(actor: ActorUpdateResult) -> dict[str, float]:
    """The actor's loss, absent when it took no step (TD3 between delayed updates)."""
    return {} if math.isnan(actor.loss) else {"losses/actor": actor.loss}


def _actor_extras(actor: ActorUpdateResult) -> dict[str, float]:
    fraction = actor.positive_fraction
    out = {} if math.isnan(fraction) else {"losses/cacla_positive_fraction": fraction}
    if actor.extra:
        out.update(actor.extra)
    return out
