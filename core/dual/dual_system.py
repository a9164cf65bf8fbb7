"""The dual system's side of one step, shared by every dual-system agent (``im2c.py``, ``i2a.py``,
``baselines.py``): regions and local world models, the meta-controller, r_int, the local models' refit, the
per-episode diagnostics and what a checkpoint keeps of them.

An agent *holds* a :class:`DualSystem` beside its learner and replay and calls it in its algorithm box's
order: :meth:`DualSystem.locate` (Alg. 2 lines 10-11; it returns the step's start, φ_t and its node n, which
the agent keeps until the step's transition arrives), :meth:`DualSystem.decide` (12-19),
:meth:`DualSystem.observe` (22-25: r_int, r = r_ext + r_int into the agent's replay, one Eq. 5 step; and the
refit repair when due), :meth:`DualSystem.diagnostics` at each episode's end. The readings of every mechanism
(`core.dual.readings`) are resolved once, here, and handed to the world models and the planner alike; so is
the learner's value, which a planner reading with ``terminal`` reads at its plans' ends once the run has seen
a positive extrinsic reward (:meth:`DualSystem.terminal_value`, docs/dual-system.md item 24).

Per-episode diagnostics (the data behind Fig. 9), keys ``dual/…``: ``model_error`` (mean Eq. 8 error of the
real transitions), ``no_change_error`` (the same error of the predictor φ̂′ = φ_t, r̂ = 0: the latent scale
the model error is read against), ``mb_decisions`` / ``mf_decisions`` (counts; model-based includes
``steered_decisions``, an aiming planner's steps steered by its aim alone where the models are not trusted,
`core.dual.meta_controller`), ``horizon`` (mean H of the planned decisions, NaN when none), ``itm_nodes``,
``imagined`` (latent transitions added), ``intrinsic_reward`` (mean r_int), ``region_rint_mean`` /
``region_rint_std`` (the r_int signal of the live regions at the episode's end: its mean, a cost or bonus per
step, and its spread, its dependence on the region), ``plan_loss_drop`` (mean L_plan decrease over the K MPC
steps), ``plan_action_shift`` (mean max-abs difference between the executed MPC action and the actor's
μ(φ_t)), with ``dual.refit_every`` set, ``refit_error`` (mean Eq. 8 error of the refit batches before the
step), and with an aiming planner, ``aimed_decisions`` (decisions whose plan was pulled toward a goal),
``babbled_decisions`` (those whose goal was babbled past the map's edge, `core.dual.goal_babbling`) and
``aim_contrast`` (the mean pull length w of the aimed decisions, before the scale c; a babbled goal's is
floored at `core.dual.goal_babbling.FLOOR`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from core.config import DualConfig
from core.dual.meta_controller import MetaController
from core.dual.planning import ActorFn, PlanResult, Rollout, TerminalValue
from core.dual.readings import Readings, resolve
from core.dual.world_models import LocalWorldModels
from core.modelfree.agent import Transition
from core.modelfree.replay import PixelBatch, PixelReplay

Encoder = Callable[[torch.Tensor], torch.Tensor]
"""φ = f(s) of a batch of stored observations, on the CPU, without gradient (the agent's ``encode_batch``)."""


@dataclass(frozen=True)
class StepStart:
    """Where a real step starts (Alg. 2 lines 9-11): φ_t ``[1, latent]`` and its best-matching node n."""

    phi: torch.Tensor
    node: int


class EpisodeCounters:
    """Per-episode sums behind the ``dual/…`` diagnostics."""

    def __init__(self) -> None:
        self.errors: list[float] = []
        self.naive_errors: list[float] = []
        self.intrinsic: list[float] = []
        self.horizons: list[int] = []
        self.plan_drops: list[float] = []
        self.action_shifts: list[float] = []
        self.refit_errors: list[float] = []
        self.mb_decisions = 0
        self.steered = 0
        self.aim_weights: list[float] = []
        self.babbled = 0
        self.mf_decisions = 0
        self.imagined = 0


def mean_or_nan(values: list[float] | list[int]) -> float:
    return float(np.mean(values)) if values else math.nan


class DualSystem:
    """Local world models over regions, the meta-controller (or none), and their bookkeeping."""

    def __init__(
        self,
        dual: DualConfig,
        latent_dim: int,
        action_dim: int,
        rng: np.random.Generator,
        encode: Encoder,
        *,
        regions: bool = True,
        arbitration: bool = True,
        fixed_horizon: int | None = None,
        value: TerminalValue | None = None,
    ) -> None:
        self.config = dual
        self.readings: Readings = resolve(dual)
        """Every mechanism's reading, resolved once (``dual.regions``, ``dual.planner``, ...)."""
        self.rng = rng
        """The run's generator (the agent's): the refit's replay draws."""
        self.encode = encode
        self.value = value
        """The learner's value and its gradient (the agent's), for a planner reading with ``terminal``."""
        self.rewarded = False
        """Whether a positive extrinsic reward was seen: only then does ``value`` join plans (item 24)."""
        model_seed = int(rng.integers(0, 2**62))
        self.world = LocalWorldModels(dual, latent_dim, action_dim, regions=regions,
                                      generator=torch.Generator().manual_seed(model_seed),
                                      readings=self.readings)
        if dual.arbitration == "model_free":  # ablation: the model-based system is never picked
            arbitration = False
        self.meta = MetaController(self.world, dual, fixed_horizon=fixed_horizon) if arbitration else None
        self.counters = EpisodeCounters()
        self.total_imagined = 0
        self.total_mb_decisions = 0
        self.total_mf_decisions = 0

    # -- acting (Alg. 2 lines 10-19) -------------------------------------------------------------
    def locate(self, phi: torch.Tensor) -> StepStart:
        """Lines 10-11: the ITM update with φ_t ``[1, latent]``; the step's start: φ_t and the node n it
        matched."""
        return StepStart(phi=phi, node=self.world.observe_state(phi[0]))

    def decide(self, start: StepStart, actor: ActorFn) -> tuple[np.ndarray, Rollout | None]:
        """Lines 12-19: the meta-controller's action before exploration, and its rollout when model-based.
        A planner whose reading has ``terminal`` reads the learner's value at the plan's end once the run has
        seen a positive extrinsic reward (`terminal_value`)."""
        phi, node = start.phi, start.node
        if self.meta is None:
            self._count_model_free()
            return actor(phi)[0].numpy(), None
        decision = self.meta.decide(phi, node, actor, self.terminal_value())
        if decision.aim is not None:
            self.counters.aim_weights.append(decision.aim.weight)
            self.counters.babbled += int(decision.aim.babbled)
        if decision.steered:  # by the aim alone: no rollout, nothing to imagine
            self.counters.mb_decisions += 1
            self.counters.steered += 1
            self.total_mb_decisions += 1
            return decision.action.numpy(), None
        if decision.model_based and decision.rollout is not None:
            self._count_model_based(decision.rollout, decision.plan)
            return decision.action.numpy(), decision.rollout
        self._count_model_free()
        return decision.action.numpy(), None

    def terminal_value(self) -> TerminalValue | None:
        """The learner's value for the plan's end, or None before the first positive extrinsic reward
        (docs/dual-system.md, item 24): until the critic has seen a reward beyond the action cost its value
        carries only SAC's entropy bonus (and the cost's echo), whose gradient the normalised Eq. 7 step would
        follow at full length — on the noisy TV, with no reward at all, that cost coverage (item 23). A reward
        > 0 is the sign of a goal in the sparse tasks (MountainCar's flag, the grasp, the swing-up's and the
        reacher's target); a task whose rewards are all costs (≤ 0) never opens it, and its planner keeps the
        predicted costs of its d_max steps."""
        return self.value if self.rewarded else None

    def _count_model_free(self) -> None:
        self.counters.mf_decisions += 1
        self.total_mf_decisions += 1

    def _count_model_based(self, rollout: Rollout, plan: PlanResult | None) -> None:
        self.counters.horizons.append(rollout.depth)
        self.counters.mb_decisions += 1
        self.total_mb_decisions += 1
        if plan is not None:
            self.counters.plan_drops.append(plan.initial_loss - plan.final_loss)
            # How far the MPC moved the executed action from μ(φ_t), the rollout's first action.
            initial = rollout.actions[0].clamp(-1.0, 1.0)
            self.counters.action_shifts.append(float((plan.action - initial).abs().max()))

    def count_imagined(self, count: int) -> None:
        """``count`` imagined transitions made (I2A's imagination, `core.dual.imagination`)."""
        self.counters.imagined += count
        self.total_imagined += count

    # -- observing (Alg. 2 lines 21-25) ----------------------------------------------------------
    def observe(self, start: StepStart | None, next_phi: torch.Tensor, transition: Transition,
                replay: PixelReplay, steps: int) -> None:
        """Lines 22-25 of the step that began at ``start``, given φ_{t+1} (line 21, the agent's encoder):
        r_int and one Eq. 5 step of M_n, R_n (22, 25); r = r_ext + r_int into ``replay`` (23-24); then, when
        ``steps`` real steps make it due, the refit repair (`refit`)."""
        if start is None:
            raise RuntimeError("observe() without a preceding act(obs, explore=True)")
        r_int = self.learn(start, next_phi, transition)  # lines 22 and 25
        replay.add(transition.action, transition.reward + r_int, transition.next_obs,  # lines 23-24
                   transition.terminated, reward_ext=transition.reward)
        if self.refit_due(steps):
            self.refit(replay)

    def learn(self, start: StepStart, next_phi: torch.Tensor, transition: Transition) -> float:
        """Lines 22 and 25: the Eq. 8 error of M_n, R_n before their update, LP of n, one Eq. 5 step; returns
        r_int of the transition (line 22, ``dual.intrinsic``)."""
        phi, reward = start.phi, transition.reward
        self.rewarded = self.rewarded or reward > 0.0
        action = torch.as_tensor(transition.action, dtype=torch.float32)
        feedback = self.world.learn_transition(start.node, phi[0], action, reward, next_phi[0],
                                               transition.terminated)
        self.counters.errors.append(feedback.error)
        self.counters.naive_errors.append(self._no_change_error(phi, next_phi[0], reward))
        self.counters.intrinsic.append(feedback.intrinsic_reward)
        return feedback.intrinsic_reward

    def _no_change_error(self, phi: torch.Tensor, next_phi: torch.Tensor, reward: float) -> float:
        """Eq. 8 error of predicting "nothing changes" (φ̂′ = φ_t, r̂ = 0): the scale ``dual/model_error`` is
        read against, since the encoder's latent scale grows by about 100× during training."""
        bank = self.world.bank
        error = bank.errors(phi, torch.zeros(1), next_phi.reshape(1, -1), torch.tensor([float(reward)]))
        return float(error[0])

    def refit_due(self, steps: int) -> bool:
        """``dual.refit_every`` (not in the paper): whether the local models refit after real step ``steps``.
        """
        every = self.config.refit_every
        return bool(every) and steps % every == 0

    def refit(self, replay: PixelReplay) -> None:
        """Refit the local models to the current encoder's latents.

        The encoder keeps training (Eq. 4), so the latents a node's model learned from drift away from what
        f_ω now produces. Every ``refit_every`` real steps, ``refit_batch`` replayed real transitions,
        re-encoded with the current encoder, each take one Eq. 5 step of their nearest node.
        """
        batch = replay.sample(self.config.refit_batch, self.rng)
        self.refit_on(batch, self.encode(torch.cat([batch.obs, batch.next_obs])))

    def refit_on(self, batch: PixelBatch, latents: torch.Tensor) -> None:
        """`refit`'s Eq. 5 steps on the replayed ``batch`` re-encoded as ``latents`` (φ of obs, then of next
        obs)."""
        count = batch.obs.shape[0]
        errors = self.world.refit(latents[:count], batch.action, batch.reward_ext, latents[count:],
                                  batch.terminated)
        self.counters.refit_errors.append(float(errors.mean()))

    # -- diagnostics and persistence -------------------------------------------------------------
    def diagnostics(self) -> dict[str, float]:
        """The episode's ``dual/…`` diagnostics (module docstring); resets the counters."""
        c = self.counters
        out = {
            "dual/model_error": mean_or_nan(c.errors),
            "dual/no_change_error": mean_or_nan(c.naive_errors),
            "dual/mb_decisions": float(c.mb_decisions),
            "dual/steered_decisions": float(c.steered),
            "dual/mf_decisions": float(c.mf_decisions),
            "dual/horizon": mean_or_nan(c.horizons),
            "dual/itm_nodes": float(self.world.num_nodes),
            "dual/imagined": float(c.imagined),
            "dual/intrinsic_reward": mean_or_nan(c.intrinsic),
            **self.region_intrinsic_diagnostics(),
            "dual/plan_loss_drop": mean_or_nan(c.plan_drops),
            "dual/plan_action_shift": mean_or_nan(c.action_shifts),
        }
        if self.config.refit_every:
            out["dual/refit_error"] = mean_or_nan(c.refit_errors)
        if self.meta is not None and self.meta.planner.aim != "none":
            out["dual/aimed_decisions"] = float(len(c.aim_weights))
            out["dual/babbled_decisions"] = float(c.babbled)
            out["dual/aim_contrast"] = mean_or_nan(c.aim_weights)
        self.counters = EpisodeCounters()
        return out

    def region_intrinsic_diagnostics(self) -> dict[str, float]:
        """At the episode's end, the r_int signal of every live region (before any centring): its mean over
        the regions (``dual/region_rint_mean``, what acts like a cost or bonus per step) and its standard
        deviation (``dual/region_rint_std``, how much it depends on where the agent is)."""
        values = self.world.region_intrinsic_rewards(self.world.alive_regions())
        return {"dual/region_rint_mean": float(values.mean()), "dual/region_rint_std": float(values.std())}

    def state_dict(self) -> dict[str, Any]:
        return {
            "world": self.world.state_dict(),
            "total_imagined": self.total_imagined,
            "total_mb_decisions": self.total_mb_decisions,
            "total_mf_decisions": self.total_mf_decisions,
            "rewarded": self.rewarded,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.world.load_state_dict(state["world"])
        self.total_imagined = int(state["total_imagined"])
        self.total_mb_decisions = int(state["total_mb_decisions"])
        self.total_mf_decisions = int(state["total_mf_decisions"])
        self.rewarded = bool(state.get("rewarded", False))  # checkpoints before item 24: none seen
