"""I2A's imagination (Algorithm 3 lines 13-21 and 35-36), one object chosen once: where imagined latent
transitions come from, when a rollout stops, and how deep it goes.

`make_imagination` picks it from the dual system's ``dual.imagination`` reading and the agent's rollout stop;
the I2A agent (``core.dual.i2a``) asks it twice per step: :meth:`Imagination.after_decide` once after the
meta-controller's decision (act time) and :meth:`Imagination.minibatch` once per learner update (learn time).
The learner learns from what it returns in :meth:`core.modelfree.learners.base.Learner.update`.

- **Where from** (``Imagination.source`` of the reading): `ActTimeImagination` (``paper``, the text and the
  released code) keeps the act-time rollouts in B_latent (line 17) and samples the latent minibatch from it;
  `LearnTimeImagination` (``repaired``) stores nothing and rolls out from the pixel minibatch's states,
  encoded by the current encoder, at every update. With the latter, lines 13-21 of Alg. 3 make only the
  planner's rollout (Alg. 1), which is not kept.
- **When a rollout stops** (`RolloutStop`, the agent's method): ``reliable`` — Alg. 1's rule, go on while the
  region is reliable (I2A); ``la`` — LA-Imagination's, a rollout starts with probability
  p_n = min(1, c / ⟨e_n⟩) and continues into each next region n_i with that region's p_{n_i}
  (DDPG+LA-Imagination, Section 3; [42]; c = ``dual.imagination_prob_scale``). A region without any recorded
  error has p = 0. At act time the reliable rollout is the planner's own (``after_decide``'s ``rollout``); the
  LA one is drawn there.
- **How deep**: act time, D_max (the planner's rollouts); learn time, ``dual.imagination_depth`` (None:
  D_max).

Why learn time is the repair (docs/dual-system.md, "Imagination"): B_latent keeps the act-time rollouts for
the whole run (200k rows never wrap in a 12k-step run), so half of every critic and actor batch holds latents
of an encoder long gone — at the start of training about 100× smaller than now. At learn time each imagined
transition is kept with the probability `LocalWorldModels.imagination_share` of the node that predicted it
(`core.dual.readings.Imagination.gate`: how much better than "nothing changes" that node's model is on its
held-out transitions), and carries ``done`` from the model's termination head
(`core.dual.readings.Imagination.termination`); a rollout stops after a predicted termination.
"""

from __future__ import annotations

import math
from typing import Any, Literal, Protocol

import numpy as np
import torch

from core.dual.dual_system import DualSystem, Encoder, StepStart
from core.dual.model_bank import ModelPrediction
from core.dual.planning import ActorFn, Rollout, model_rollout
from core.dual.world_models import LocalWorldModels
from core.modelfree.replay import LatentBatch, LatentReplay

RolloutStop = Literal["reliable", "la"]
"""When an imagined rollout stops: Alg. 1's reliability rule (I2A) or LA-Imagination's error-driven one."""


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
        stop: RolloutStop = "reliable",
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


class Imagination(Protocol):
    """I2A's imagination (module docstring): what the agent asks after each decision and at each update."""

    def after_decide(self, start: StepStart, rollout: Rollout | None) -> None:
        """Act time (Alg. 3 lines 13-21), after the meta-controller's decision from ``start``; ``rollout`` is
        the planner's model-based rollout (None when the model-free system acted)."""
        ...

    def minibatch(self, obs: torch.Tensor) -> LatentBatch | None:
        """The latent minibatch of one update (lines 35-36) beside the pixel minibatch of states ``obs``."""
        ...

    def diagnostics(self) -> dict[str, float]: ...

    def replay_state_dict(self) -> dict[str, Any]: ...

    def load_replay_state_dict(self, state: dict[str, Any]) -> None: ...


class ActTimeImagination:
    """The ``paper`` reading: act-time rollouts into B_latent (line 17), latent minibatches drawn from it."""

    def __init__(self, dual: DualSystem, actor: ActorFn, rng: np.random.Generator, stop: RolloutStop,
                 latent_dim: int, action_dim: int) -> None:
        config = dual.config
        self.dual, self.actor, self.rng, self.stop = dual, actor, rng, stop
        self.d_max, self.la_scale = config.d_max, config.imagination_prob_scale
        self.batch_size = config.latent_batch_size
        self.replay = LatentReplay(config.latent_buffer_size, latent_dim, action_dim)  # B_latent, line 5

    def after_decide(self, start: StepStart, rollout: Rollout | None) -> None:
        if self.stop == "la":
            rollout = la_imagination_rollout(start.phi, start.node, self.dual.world, self.actor, self.d_max,
                                             self.la_scale, self.rng)
        if rollout is None or rollout.depth == 0:
            return
        self.replay.add_batch(rollout.latents, rollout.actions, rollout.rewards, rollout.next_latents)  # 17
        self.dual.count_imagined(rollout.depth)

    def minibatch(self, obs: torch.Tensor) -> LatentBatch | None:
        if len(self.replay) == 0:
            return None
        return self.replay.sample(self.batch_size, self.rng)

    def diagnostics(self) -> dict[str, float]:
        return {"charts/latent_replay_size": float(len(self.replay))}

    def replay_state_dict(self) -> dict[str, Any]:
        return {"latent": self.replay.state_dict()}

    def load_replay_state_dict(self, state: dict[str, Any]) -> None:
        self.replay.load_state_dict(state["latent"])


class LearnTimeImagination:
    """The ``repaired`` readings: rollouts from each pixel minibatch's states, encoded by the current encoder,
    at most ``dual.imagination_depth`` (None: D_max) model steps, gated, used once (`imagine`)."""

    def __init__(self, dual: DualSystem, actor: ActorFn, rng: np.random.Generator, stop: RolloutStop,
                 encode: Encoder) -> None:
        config = dual.config
        self.dual, self.actor, self.rng, self.encode = dual, actor, rng, encode
        self.model = RegionModels(dual.world, rng, stop=stop, la_scale=config.imagination_prob_scale)
        self.depth = config.d_max if config.imagination_depth is None else config.imagination_depth
        self.limit = config.latent_batch_size

    def after_decide(self, start: StepStart, rollout: Rollout | None) -> None:
        """Nothing is kept at act time: the planner's rollout served its decision."""

    def minibatch(self, obs: torch.Tensor) -> LatentBatch | None:
        latent = imagine(self.encode(obs), self.model, self.actor, self.depth, self.rng, self.limit)
        self.dual.count_imagined(0 if latent is None else latent.latent.shape[0])
        return latent

    def diagnostics(self) -> dict[str, float]:
        return {}

    def replay_state_dict(self) -> dict[str, Any]:
        return {}

    def load_replay_state_dict(self, state: dict[str, Any]) -> None:
        """Nothing stored (a checkpoint of an older run may hold an unused B_latent: ignored)."""


def make_imagination(dual: DualSystem, actor: ActorFn, rng: np.random.Generator, stop: RolloutStop,
                     encode: Encoder, latent_dim: int, action_dim: int) -> Imagination:
    """The imagination of ``dual``'s reading (``dual.imagination``) and the rollout ``stop``, chosen once."""
    if dual.readings.imagination.at_learn_time:
        return LearnTimeImagination(dual, actor, rng, stop, encode)
    return ActTimeImagination(dual, actor, rng, stop, latent_dim, action_dim)

