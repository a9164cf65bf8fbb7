"""The dual-system methods as agents of the shared trainer: im2c, i2a, cmc, la-imagination, mve.

`core.runs.methods` lists their factories under the ``--algo`` names. Every method is the model-free
agent (`core.modelfree.agent.ModelFreeAgent`, DDPG or CACLA by ``agent.ac``) plus the pieces it adds:

==================  ========  ============  =================  =============  ===============
method              regions   arbitration   MPC horizon        r_int = −LP    imagination
==================  ========  ============  =================  =============  ===============
im2c (Alg. 2)       ITM       LP ≥ 0        adaptive (Alg. 1)  yes            —
i2a (Alg. 3)        ITM       LP ≥ 0        adaptive (Alg. 1)  yes            the Alg. 1 rollout
cmc (DDPG+CMC)      global    LP ≥ 0        fixed, cmc_horizon yes            —
la-imagination      ITM       — (MF)        —                  yes            random, error-set depth
mve (MVE-DDPG)      global    — (MF)        —                  —              value expansion H
==================  ========  ============  =================  =============  ===============

One training step of the ITM methods (Alg. 2 / Alg. 3), split over the trainer's hooks:

- ``act(obs, explore=True)``: φ_t = f(s_t) (line 9); ITM update, node n (10-11); the meta-controller's
  decision (12-19; I2A stores the rollout's H imagined transitions in B_latent, Alg. 3 line 17); noise
  (20). ``explore=False`` is the deployed policy μ(f(s)) and changes nothing.
- ``observe(transition)``: φ_{t+1} = f(s_{t+1}); the Eq. 8 error of M_n, R_n before its update, LP of n
  updated, r_int = −LP (22), r = r_ext + r_int stored (23-24), one Eq. 5 step of n's model (25).
- ``update_after_step`` / ``update_after_episode``: the learner update on the configured schedule
  (26-28; for I2A and LA-Imagination the pixel + latent update of Alg. 3 lines 34-37).

Per-episode diagnostics (the data behind Fig. 9), keys ``dual/…``: ``model_error`` (mean Eq. 8 error
of the real transitions), ``no_change_error`` (the same error of the predictor φ̂′ = φ_t, r̂ = 0: the
latent scale the model error is read against), ``mb_decisions`` / ``mf_decisions`` (counts),
``horizon`` (mean H of the model-based decisions, NaN when none), ``itm_nodes``, ``imagined`` (latent
transitions added), ``intrinsic_reward`` (mean r_int), ``plan_loss_drop`` (mean L_plan decrease over
the K MPC steps), ``plan_action_shift`` (mean max-abs difference between the executed MPC action and the
actor's μ(φ_t)),
and with ``dual.refit_every`` set, ``refit_error`` (mean Eq. 8 error of the refit batches before the step).
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
import torch

from core.config import Config
from core.dual.imagination import RegionModels, imagination_update, imagine, la_imagination_rollout
from core.dual.meta_controller import MetaController
from core.dual.planning import PlanResult, Rollout
from core.dual.value_expansion import ValueExpansionActorCritic
from core.dual.world_models import LocalWorldModels
from core.envs.spec import EnvSpec
from core.modelfree.agent import ModelFreeAgent, Transition
from core.modelfree.replay import LatentBatch, LatentReplay, PixelReplay

Imagination = Literal["none", "adaptive", "la"]


class _EpisodeCounters:
    """Per-episode sums behind the ``dual/…`` diagnostics."""

    def __init__(self) -> None:
        self.errors: list[float] = []
        self.naive_errors: list[float] = []
        self.intrinsic: list[float] = []
        self.horizons: list[int] = []
        self.plan_drops: list[float] = []
        self.action_shifts: list[float] = []
        self.refit_errors: list[float] = []
        self.mf_decisions = 0
        self.imagined = 0


def _mean(values: list[float] | list[int]) -> float:
    return float(np.mean(values)) if values else math.nan


class DualSystemAgent(ModelFreeAgent):
    """The model-free agent plus regions, local models, learning progress, arbitration and imagination."""

    def __init__(
        self,
        config: Config,
        spec: EnvSpec,
        rng: np.random.Generator,
        *,
        regions: bool = True,
        arbitration: bool = True,
        fixed_horizon: int | None = None,
        intrinsic: bool = True,
        imagination: Imagination = "none",
    ) -> None:
        super().__init__(config, spec, rng)
        dual = config.dual
        latent_dim = config.net.latent_dim
        self.arbitration = arbitration
        self.intrinsic = intrinsic
        self.imagination: Imagination = imagination
        model_seed = int(rng.integers(0, 2**62))
        self.world = LocalWorldModels(dual, latent_dim, spec.action_dim, regions=regions,
                                      generator=torch.Generator().manual_seed(model_seed))
        if dual.arbitration == "model_free":  # ablation: the model-based system is never picked
            arbitration = False
        self.meta = MetaController(self.world, dual, fixed_horizon=fixed_horizon) if arbitration else None
        self.latent_replay: LatentReplay | None = None
        if imagination != "none":
            # Alg. 3 line 5: B_pixel (60k in the paper) beside B_latent (200k).
            self.replay = PixelReplay(dual.pixel_buffer_size, spec.obs_shape, spec.action_dim, spec.obs_dtype)
            self.latent_replay = LatentReplay(dual.latent_buffer_size, latent_dim, spec.action_dim)
        self._phi: torch.Tensor | None = None
        self._node = 0
        self._pending_intrinsic = 0.0
        self.counters = _EpisodeCounters()
        self.total_imagined = 0
        self.total_mb_decisions = 0
        self.total_mf_decisions = 0

    # -- acting ----------------------------------------------------------------------------------
    def _encode(self, obs: np.ndarray) -> torch.Tensor:
        obs_tensor = torch.from_numpy(np.ascontiguousarray(obs)).unsqueeze(0).to(self.device)
        return self.learner.encode(obs_tensor).cpu()

    def _actor(self, latent: torch.Tensor) -> torch.Tensor:
        return self.learner.policy(latent.to(self.device)).cpu()

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        if not explore:
            return super().act(obs, explore=False)
        phi = self._encode(obs)  # line 9
        node = self.world.observe_state(phi[0])  # lines 10-11
        self._phi, self._node = phi, node
        if self.meta is not None:  # lines 12-19
            decision = self.meta.decide(phi, node, self._actor)
            action = decision.action.numpy()
            if decision.model_based and decision.rollout is not None:
                self._count_model_based(decision.rollout, decision.plan)
                if self.imagination == "adaptive" and self._act_time_imagination:
                    self._store_imagined(decision.rollout)  # Alg. 3 line 17
            else:
                self.counters.mf_decisions += 1
                self.total_mf_decisions += 1
        else:
            action = self._actor(phi)[0].numpy()
            self.counters.mf_decisions += 1
            self.total_mf_decisions += 1
        if self.imagination == "la" and self._act_time_imagination:
            dual = self.config.dual
            rollout = la_imagination_rollout(phi, node, self.world, self._actor, dual.d_max,
                                             dual.imagination_prob_scale, self.rng)
            self._store_imagined(rollout)
        noisy = self.noise.perturb(action, self.steps, self.rng)  # line 20
        return noisy.astype(np.float32), {}

    @property
    def _act_time_imagination(self) -> bool:
        """Imagination stored in B_latent at act time (paper) rather than made at learn time (the repair)."""
        return self.config.dual.imagination_source == "act_time"

    def _count_model_based(self, rollout: Rollout, plan: PlanResult | None) -> None:
        self.counters.horizons.append(rollout.depth)
        self.total_mb_decisions += 1
        if plan is not None:
            self.counters.plan_drops.append(plan.initial_loss - plan.final_loss)
            # How far the MPC moved the executed action from μ(φ_t), the rollout's first action.
            initial = rollout.actions[0].clamp(-1.0, 1.0)
            self.counters.action_shifts.append(float((plan.action - initial).abs().max()))

    def _store_imagined(self, rollout: Rollout) -> None:
        if rollout.depth == 0 or self.latent_replay is None:
            return
        self.latent_replay.add_batch(rollout.latents, rollout.actions, rollout.rewards, rollout.next_latents)
        self.counters.imagined += rollout.depth
        self.total_imagined += rollout.depth

    # -- storing ---------------------------------------------------------------------------------
    def stored_reward(self, transition: Transition) -> float:
        """r_t = r_t^ext + r_t^int (Alg. 2 line 23)."""
        return transition.reward + self._pending_intrinsic

    def observe(self, transition: Transition) -> None:
        if self._phi is None:
            raise RuntimeError("observe() without a preceding act(obs, explore=True)")
        next_phi = self._encode(transition.next_obs)
        action = torch.as_tensor(transition.action, dtype=torch.float32)
        feedback = self.world.learn_transition(self._node, self._phi[0], action, transition.reward,
                                               next_phi[0], transition.terminated)  # lines 22 and 25
        self._pending_intrinsic = feedback.intrinsic_reward if self.intrinsic else 0.0
        self.counters.errors.append(feedback.error)
        self.counters.naive_errors.append(self._no_change_error(next_phi[0], transition.reward))
        self.counters.intrinsic.append(self._pending_intrinsic)
        super().observe(transition)  # line 24, with stored_reward
        self._pending_intrinsic = 0.0
        self._phi = None
        refit_every = self.config.dual.refit_every
        if refit_every and self.steps % refit_every == 0:
            self._refit_models()

    def _no_change_error(self, next_phi: torch.Tensor, reward: float) -> float:
        """Eq. 8 error of predicting "nothing changes" (φ̂′ = φ_t, r̂ = 0): the scale ``dual/model_error`` is
        read against, since the encoder's latent scale grows by about 100× during training."""
        bank = self.world.bank
        error = bank.errors(self._phi, torch.zeros(1), next_phi.reshape(1, -1), torch.tensor([float(reward)]))
        return float(error[0])

    def _refit_models(self) -> None:
        """``dual.refit_every`` (not in the paper): refit the local models to the current encoder's latents.

        The encoder keeps training (Eq. 4), so the latents a node's model learned from drift away from what
        f_ω now produces. Every ``refit_every`` real steps, ``refit_batch`` replayed real transitions are
        re-encoded with the current encoder and each touched node takes one Eq. 5 step on them.
        """
        batch = self.replay.sample(self.config.dual.refit_batch, self.rng)
        count = batch.obs.shape[0]
        with torch.no_grad():
            latents = self.learner.encode(torch.cat([batch.obs, batch.next_obs]).to(self.device)).cpu()
        errors = self.world.refit(latents[:count], batch.action, batch.reward_ext, latents[count:],
                                  batch.terminated)
        self.counters.refit_errors.append(float(errors.mean()))

    # -- learning --------------------------------------------------------------------------------
    def learn_minibatch(self) -> dict[str, float]:
        if self.latent_replay is None:
            return super().learn_minibatch()
        batch = self.replay.sample(self.config.agent.batch_size, self.rng)
        latent = None
        if not self._act_time_imagination:
            latent = self._imagine_from(batch.obs)
        elif len(self.latent_replay) > 0:
            latent = self.latent_replay.sample(self.config.dual.latent_batch_size, self.rng)
        if self.device.type != "cpu":
            batch = type(batch)(*(t.to(self.device) for t in batch))
            latent = None if latent is None else type(latent)(*(t.to(self.device) for t in latent))
        self.updates += 1
        return imagination_update(self.learner, batch, latent,
                                  actor_on_imagined=self.config.dual.imagination_actor == "all")

    def _imagine_from(self, obs: torch.Tensor) -> LatentBatch | None:
        """Learn-time imagination (``dual.imagination_source``): rollouts from the minibatch's states, encoded
        by the current encoder (core/dual/imagination.py ``imagine``)."""
        dual = self.config.dual
        with torch.no_grad():
            phi = self.learner.encode(obs.to(self.device)).cpu()
        stop = "reliable" if self.imagination == "adaptive" else "la"
        model = RegionModels(self.world, self.rng, stop=stop, la_scale=dual.imagination_prob_scale,
                             intrinsic=self.intrinsic and dual.imagination_reward == "with_intrinsic")
        latent = imagine(phi, model, self._actor, dual.d_max, self.rng, dual.latent_batch_size)
        made = 0 if latent is None else latent.latent.shape[0]
        self.counters.imagined += made
        self.total_imagined += made
        return latent

    # -- diagnostics -----------------------------------------------------------------------------
    def episode_diagnostics(self) -> dict[str, float]:
        c = self.counters
        out = super().episode_diagnostics()
        out.update({
            "dual/model_error": _mean(c.errors),
            "dual/no_change_error": _mean(c.naive_errors),
            "dual/mb_decisions": float(len(c.horizons)),
            "dual/mf_decisions": float(c.mf_decisions),
            "dual/horizon": _mean(c.horizons),
            "dual/itm_nodes": float(self.world.num_nodes),
            "dual/imagined": float(c.imagined),
            "dual/intrinsic_reward": _mean(c.intrinsic),
            "dual/plan_loss_drop": _mean(c.plan_drops),
            "dual/plan_action_shift": _mean(c.action_shifts),
        })
        if self.config.dual.refit_every:
            out["dual/refit_error"] = _mean(c.refit_errors)
        if self.latent_replay is not None:
            out["charts/latent_replay_size"] = float(len(self.latent_replay))
        self.counters = _EpisodeCounters()
        return out

    # -- persistence -----------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        state = super().state_dict()
        state["dual"] = {
            "world": self.world.state_dict(),
            "total_imagined": self.total_imagined,
            "total_mb_decisions": self.total_mb_decisions,
            "total_mf_decisions": self.total_mf_decisions,
        }
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        dual = state["dual"]
        self.world.load_state_dict(dual["world"])
        self.total_imagined = int(dual["total_imagined"])
        self.total_mb_decisions = int(dual["total_mb_decisions"])
        self.total_mf_decisions = int(dual["total_mf_decisions"])

    def replay_state_dict(self) -> dict[str, Any]:
        state = super().replay_state_dict()
        if self.latent_replay is not None:
            state["latent"] = self.latent_replay.state_dict()
        return state

    def load_replay_state_dict(self, state: dict[str, Any]) -> None:
        super().load_replay_state_dict(state)
        if self.latent_replay is not None:
            self.latent_replay.load_state_dict(state["latent"])


class ValueExpansionAgent(ModelFreeAgent):
    """MVE-DDPG: model-free acting; the critic target expanded H steps through one global latent model."""

    def __init__(self, config: Config, spec: EnvSpec, rng: np.random.Generator) -> None:
        super().__init__(config, spec, rng)
        model_seed = int(rng.integers(0, 2**62))
        self.world = LocalWorldModels(config.dual, config.net.latent_dim, spec.action_dim, regions=False,
                                      generator=torch.Generator().manual_seed(model_seed))
        self.learner = ValueExpansionActorCritic(
            config.net, config.agent, spec, model=self.world.bank, horizon=config.dual.fixed_horizon
        ).to(self.device)
        self._errors: list[float] = []

    def learn_minibatch(self) -> dict[str, float]:
        batch = self.replay.sample(self.config.agent.batch_size, self.rng)
        if self.device.type != "cpu":
            batch = type(batch)(*(t.to(self.device) for t in batch))
        both = torch.cat([batch.obs, batch.next_obs])
        latents = self.learner.encode(both).cpu()
        phi, next_phi = latents[: batch.obs.shape[0]], latents[batch.obs.shape[0]:]
        errors = self.world.learn_batch(phi, batch.action.cpu(), batch.reward_ext.cpu(), next_phi)
        self._errors.append(float(errors.mean()))
        self.updates += 1
        return self.learner.update_pixels(batch)

    def episode_diagnostics(self) -> dict[str, float]:
        out = super().episode_diagnostics()
        out["dual/model_error"] = _mean(self._errors)
        out["dual/horizon"] = float(self.config.dual.fixed_horizon)
        self._errors = []
        return out

    def state_dict(self) -> dict[str, Any]:
        state = super().state_dict()
        state["dual"] = {"world": self.world.state_dict()}
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.world.load_state_dict(state["dual"]["world"])


def make_im2c(config: Config, spec: EnvSpec, rng: np.random.Generator) -> DualSystemAgent:
    """IM2C (Alg. 2): ITM regions, LP arbitration, adaptive-depth gradient MPC, r_int = −LP."""
    return DualSystemAgent(config, spec, rng)


def make_i2a(config: Config, spec: EnvSpec, rng: np.random.Generator) -> DualSystemAgent:
    """I2A (Alg. 3): IM2C plus the adaptive rollout's imagined transitions in B_latent."""
    return DualSystemAgent(config, spec, rng, imagination="adaptive")


def make_cmc(config: Config, spec: EnvSpec, rng: np.random.Generator) -> DualSystemAgent:
    """DDPG+CMC: one global model, temporal-only LP arbitration, fixed-horizon MPC (``dual.cmc_horizon``)."""
    return DualSystemAgent(config, spec, rng, regions=False, fixed_horizon=config.dual.cmc_horizon)


def make_la_imagination(config: Config, spec: EnvSpec, rng: np.random.Generator) -> DualSystemAgent:
    """DDPG+LA-Imagination: model-free acting, error-driven imagined rollouts into B_latent, r_int = −LP."""
    return DualSystemAgent(config, spec, rng, arbitration=False, imagination="la")

