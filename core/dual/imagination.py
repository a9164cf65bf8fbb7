"""Learning from imagined latent transitions: the I2A update (Alg. 3 lines 34-37) and LA-Imagination rollouts.

`imagination_update` is one minibatch update of Algorithm 3 on a pixel minibatch from B_pixel and a
latent minibatch from B_latent:

- line 34: θ^Q fixed, encoder ω and decoder ω̃ take a step on L_combined (Eq. 4) of the pixel minibatch
  (the value term's gradient flows through a detached copy of the critic into the encoder);
- line 35: the critic θ^Q takes a step on L_Q (Eq. 1) over the pixel minibatch's latents φ = f(s)
  (detached) together with the latent minibatch's φ, the two concatenated into one batch;
- line 36: the actor strategy (DDPG Eq. 2 or CACLA Eq. 3) on the same concatenated latents;
- line 37: τ target updates.

Lines 34 and 35 touch disjoint parameters, so they are one backward pass and one step of the
critic-autoencoder's Adam (Adam is per parameter: identical to two separate steps). With
``critic_passes`` > 1 (released-code schedule) both lines repeat that many times.

`la_imagination_rollout` is the imagination of DDPG+LA-Imagination (Section 3; [42]): from φ_t an
on-policy rollout starts with probability p_n = min(1, c / ⟨e_n⟩), inversely proportional to the
average error ⟨e_n⟩ of the current region (c = ``dual.imagination_prob_scale``), and continues into
each next region n_i with that region's p_{n_i} (so the errors of the regions traversed set the depth),
up to D_max. A region without any recorded error has p = 0.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch.func import functional_call

from core.dual.planning import ActorFn, Rollout, model_rollout
from core.dual.world_models import LocalWorldModels
from core.modelfree.actor_critic import ActorCritic
from core.modelfree.replay import LatentBatch, PixelBatch


def imagination_update(
    learner: ActorCritic, pixel: PixelBatch, latent: LatentBatch | None
) -> dict[str, float]:
    """Algorithm 3 lines 34-37 on one pixel and one latent minibatch (``latent`` None: pixel only)."""
    cfg = learner.agent_config
    obs = learner.encoder.prepare(pixel.obs)
    with torch.no_grad():
        next_phi = learner.target_encoder(learner.encoder.prepare(pixel.next_obs))
        y_pixel = learner.td_target(pixel.reward, next_phi, pixel.terminated)
        if latent is not None:
            y_latent = learner.td_target(latent.reward, latent.next_latent, latent.done)
            y_all = torch.cat([y_pixel, y_latent])
            action_all = torch.cat([pixel.action, latent.action])
        else:
            y_all, action_all = y_pixel, pixel.action
    rec_loss = q_encoder = q_critic = torch.zeros(())
    for _ in range(cfg.critic_passes):
        phi = learner.encoder(obs)
        rec_loss = (learner.decoder(phi) - obs).pow(2).mean()
        frozen = {name: p.detach() for name, p in learner.critic.named_parameters()}
        q_encoder = (y_pixel - functional_call(learner.critic, frozen, (phi, pixel.action))).pow(2).mean()
        phi_all = phi.detach() if latent is None else torch.cat([phi.detach(), latent.latent])
        q_critic = (y_all - learner.critic(phi_all, action_all)).pow(2).mean()
        loss = cfg.lambda_rec * rec_loss + cfg.lambda_q * q_encoder + cfg.lambda_q * q_critic
        learner.critic_optimizer.zero_grad(set_to_none=True)
        loss.backward()
        learner.critic_optimizer.step()
    with torch.no_grad():
        phi = learner.encoder(obs)
    phi_all = phi if latent is None else torch.cat([phi, latent.latent])
    actor = learner.actor_update(learner, phi_all, action_all, y_all)
    learner.update_targets()
    out = {
        "losses/critic": float(q_critic.detach()),
        "losses/critic_encoder": float(q_encoder.detach()),
        "losses/rec": float(rec_loss.detach()),
        "losses/actor": actor.loss,
        "losses/td_target_mean": float(y_pixel.mean()),
    }
    if not math.isnan(actor.positive_fraction):
        out["losses/cacla_positive_fraction"] = actor.positive_fraction
    return out


def imagination_probability(world: LocalWorldModels, node: int, scale: float) -> float:
    """p_n = min(1, scale / ⟨e_n⟩); 0 for a region without errors yet, 1 for a zero-error region."""
    error = world.mean_error(node)
    if math.isnan(error):
        return 0.0
    if error <= 0.0:
        return 1.0
    return min(1.0, scale / error)


def la_imagination_rollout(
    phi: torch.Tensor,
    node: int,
    world: LocalWorldModels,
    actor: ActorFn,
    d_max: int,
    scale: float,
    rng: np.random.Generator,
) -> Rollout:
    """LA-Imagination: start with p_{n_0}, continue into region n_i with p_{n_i}, at most D_max steps."""
    return model_rollout(
        phi, node, world.bank, actor, d_max,
        continue_at=lambda _i, n: bool(rng.random() < imagination_probability(world, n, scale)),
        locate=world.nearest,
    )
