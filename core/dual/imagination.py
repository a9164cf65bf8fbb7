"""Where imagined latent transitions come from: LA-Imagination's rollouts and learn-time imagination.

The learner learns from them in :meth:`core.modelfree.learners.base.Learner.update_with_imagination`
(Algorithm 3, lines 34-37); the I2A agent (``core.dual.i2a``) decides which of these feeds it.

`la_imagination_rollout` is the imagination of DDPG+LA-Imagination (Section 3; [42]): from φ_t an
on-policy rollout starts with probability p_n = min(1, c / ⟨e_n⟩), inversely proportional to the
average error ⟨e_n⟩ of the current region (c = ``dual.imagination_prob_scale``), and continues into
each next region n_i with that region's p_{n_i} (so the errors of the regions traversed set the depth),
up to D_max. A region without any recorded error has p = 0.

`imagine` is the repair of where imagined transitions come from (``dual.imagination = repaired``,
docs/dual-system.md, "Imagination"): B_latent keeps the act-time rollouts of Alg. 3 line 17 for the whole run
(200k rows never wrap in a 12k-step run), so half of every critic and actor batch holds latents of an encoder
long gone — at the start of training about 100× smaller than now. Instead, at every update the pixel
minibatch's states are encoded by the current encoder and rolled out from there with the actor and the
local models, with the same stopping rule as at act time (Alg. 1: go on while the region is reliable;
LA-Imagination: with probability p_n), and used once. Each imagined transition is kept with the probability
`LocalWorldModels.imagination_share` of the node that predicted it (`core.dual.readings.Imagination.gate`:
how much better than "nothing changes" that node's model is on its held-out transitions), and carries
``done`` from the model's termination head (`Imagination.termination`); a rollout stops after a predicted
termination.
"""

from __future__ import annotations

import math
from typing import Literal, Protocol

import numpy as np
import torch

from core.dual.model_bank import ModelPrediction
from core.dual.planning import ActorFn, Rollout, model_rollout
from core.dual.world_models import LocalWorldModels
from core.modelfree.replay import LatentBatch


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


class ImaginationModel(Protocol):
    """What `imagine` rolls out: regions, a stopping rule, one-step predictions and the gate."""

    def locate(self, phi: torch.Tensor) -> np.ndarray:
        """Region of each row of ``phi [k, latent]`` (int64 ``[k]``)."""
        ...

    def proceed(self, regions: np.ndarray) -> np.ndarray:
        """Whether a rollout may take a step from each region (bool ``[k]``)."""
        ...

    def predict(self, regions: np.ndarray, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        """φ̂′, r̂ and P(done) of each row, predicted by its region's model."""
        ...

    def share(self, regions: np.ndarray) -> np.ndarray:
        """Probability of keeping a transition predicted by each region's model (``[k]``)."""
        ...


class RegionModels:
    """`ImaginationModel` over `LocalWorldModels`: Alg. 1's rule (``stop="reliable"``) or LA-Imagination's."""

    def __init__(
        self,
        world: LocalWorldModels,
        rng: np.random.Generator,
        stop: Literal["reliable", "la"] = "reliable",
        la_scale: float = 1.0,
    ) -> None:
        self.world, self.rng, self.stop, self.la_scale = world, rng, stop, la_scale

    def locate(self, phi: torch.Tensor) -> np.ndarray:
        return self.world.nearest_many(phi)

    def proceed(self, regions: np.ndarray) -> np.ndarray:
        if self.stop == "reliable":
            return self.world.reliable_many(regions)
        lp = self.world.lp
        count = lp.error_count(regions)
        error = lp.window_mean(regions)
        with np.errstate(divide="ignore"):
            p = np.where(count == 0, 0.0, np.where(error <= 0, 1.0, np.minimum(1.0, self.la_scale / error)))
        return self.rng.random(regions.shape[0]) < p

    def predict(self, regions: np.ndarray, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        """The region models' prediction: r̂ is the model's (the bank learns r_ext only; adding r_int, as real
        transitions carry in the replay, was tried and rejected, docs/dual-system.md "Imagination")."""
        return self.world.bank.predict(torch.from_numpy(regions), phi, action)

    def share(self, regions: np.ndarray) -> np.ndarray:
        return self.world.imagination_share(regions)


@torch.no_grad()
def imagine(
    phi: torch.Tensor,
    model: ImaginationModel,
    actor: ActorFn,
    depth: int,
    rng: np.random.Generator,
    limit: int,
) -> LatentBatch | None:
    """Learn-time imagination: roll the actor and ``model`` out from every row of ``phi`` (module docstring).

    Up to ``depth`` steps per start, each row continuing while ``model.proceed`` allows and no termination was
    predicted (P(done) > 0.5); each transition is kept with probability ``model.share``; at most ``limit`` of
    the kept transitions (a uniform subset) are returned, None when none was kept.
    """
    current = phi.detach().to(torch.float32).clone()
    regions = model.locate(current)
    active = model.proceed(regions)
    parts: list[tuple[torch.Tensor, ...]] = []
    for _ in range(depth):
        rows = np.flatnonzero(active)
        if rows.size == 0:
            break
        index = torch.from_numpy(rows)
        state = current[index]
        action = actor(state).reshape(rows.size, -1)
        prediction = model.predict(regions[rows], state, action)
        done = prediction.done > 0.5
        keep = torch.from_numpy(rng.random(rows.size) < model.share(regions[rows]))
        parts.append((state[keep], action[keep], prediction.reward[keep], prediction.next_latent[keep],
                      done[keep].to(torch.float32)))
        current[index] = prediction.next_latent
        regions[rows] = model.locate(prediction.next_latent)
        active[rows] = ~done.numpy() & model.proceed(regions[rows])
    if not parts:
        return None
    latent, action, reward, next_latent, done = (torch.cat(column) for column in zip(*parts, strict=True))
    if latent.shape[0] == 0:
        return None
    if latent.shape[0] > limit:
        chosen = torch.from_numpy(np.sort(rng.choice(latent.shape[0], size=limit, replace=False)))
        latent, action, reward = latent[chosen], action[chosen], reward[chosen]
        next_latent, done = next_latent[chosen], done[chosen]
    return LatentBatch(latent=latent, action=action, reward=reward, next_latent=next_latent, done=done)
