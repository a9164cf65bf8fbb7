"""The baselines of Section 4.1.2 built from the dual system's parts: DDPG+CMC, DDPG+LA-Imagination, MVE-DDPG.

Each runs over any learner (``agent.ac``; DDPG as in the paper).

* **CMC** (temporal learning progress, fixed-horizon MPC): IM2C over one global region, planning a fixed
  ``dual.cmc_horizon`` steps whenever the global model is reliable (:func:`make_cmc`).
* **LA-Imagination** (Section 3; [42]): model-free acting; imagined rollouts that start with probability
  p_n = min(1, c / ⟨e_n⟩) and go on into each next region with that region's p (the error-driven depth), into
  B_latent (:func:`make_la_imagination`; ``core.dual.imagination``, the ``la`` rollout stop).
* **MVE** (Feinberg et al. 2018; our reading in this architecture): model-free acting; the critic's Eq. 1
  target bootstraps not from V(φ′) directly but after H imagined steps of one global latent model M, R under
  the target policy,

      φ̂_0 = f′(s_{t+1}),  â_h = μ′(φ̂_h),  r̂_h = R(φ̂_h, â_h),  φ̂_{h+1} = M(φ̂_h, â_h),
      y_t = r_t + γ (1 − terminated_t) [ Σ_{h<H} γ^h r̂_h + γ^H V(φ̂_H) ],

  with V the learner's own bootstrap (DDPG: Q′(φ, μ′(φ))). H = 0 is the learner alone. The model's reward head
  predicts the extrinsic reward; imagined steps are never terminal. The model is trained on every learner
  minibatch (Eq. 5 on the online encoder's φ, φ′ of the sampled real transitions). Simplification,
  documented: MVE's "TD-k trick" (also fitting Q on the imagined states) is not applied — only the target is
  expanded.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch

from core.config import Config
from core.dual.i2a import I2A
from core.dual.im2c import IM2C
from core.dual.model_bank import ModelBank
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels
from core.envs.spec import EnvSpec
from core.modelfree.agent import (
    LearnerAgent,
    Transition,
    act_model_free,
    learner_diagnostics,
    store_extrinsic,
    to_device,
)
from core.modelfree.learners import Learner
from core.modelfree.replay import PixelReplay


def make_im2c(config: Config, spec: EnvSpec, rng: np.random.Generator) -> IM2C:
    """IM2C (Alg. 2): ITM regions, reliability arbitration, adaptive-depth gradient MPC, r_int."""
    return IM2C(config, spec, rng)


def make_i2a(config: Config, spec: EnvSpec, rng: np.random.Generator) -> I2A:
    """I2A (Alg. 3): IM2C plus the adaptive rollout's imagined transitions."""
    return I2A(config, spec, rng)


def make_cmc(config: Config, spec: EnvSpec, rng: np.random.Generator) -> IM2C:
    """DDPG+CMC: one global model, temporal-only LP arbitration, fixed-horizon MPC (``dual.cmc_horizon``)."""
    return IM2C(config, spec, rng, regions=False, fixed_horizon=config.dual.cmc_horizon)


def make_la_imagination(config: Config, spec: EnvSpec, rng: np.random.Generator) -> I2A:
    """DDPG+LA-Imagination: model-free acting, error-driven imagined rollouts into B_latent, r_int."""
    return I2A(config, spec, rng, arbitration=False, stop="la")


class ValueExpansion:
    """The H-step value expansion of the TD target through ``model`` (node 0), the learner's
    ``value_expansion`` (module docstring)."""

    def __init__(self, model: ModelBank, horizon: int) -> None:
        if horizon < 0:
            raise ValueError(f"value-expansion horizon must be >= 0, got {horizon}")
        self.model, self.horizon = model, horizon

    @torch.no_grad()
    def __call__(self, learner: Learner, next_latent: torch.Tensor) -> torch.Tensor:
        gamma = learner.agent_config.gamma
        phi = next_latent
        nodes = torch.zeros(phi.shape[0], dtype=torch.int64)
        expanded = torch.zeros(phi.shape[0])
        discount = 1.0
        for _ in range(self.horizon):
            prediction = self.model.predict(nodes, phi, learner.target_action(phi))
            expanded = expanded + discount * prediction.reward
            discount *= gamma
            phi = prediction.next_latent
        return expanded + discount * learner.bootstrap(phi)


class MVE(LearnerAgent):
    """MVE-DDPG: model-free acting and storing; the learner's target is expanded through one global latent
    model."""

    def __init__(self, config: Config, spec: EnvSpec, rng: np.random.Generator) -> None:
        super().__init__(config, spec, rng)
        self.replay = PixelReplay(config.agent.buffer_size, spec.obs_shape, spec.action_dim, spec.obs_dtype)
        model_seed = int(rng.integers(0, 2**62))
        self.world = LocalWorldModels(config.dual, self.learner.latent_dim, spec.action_dim, regions=False,
                                      generator=torch.Generator().manual_seed(model_seed),
                                      readings=resolve(config.dual))
        self.learner.value_expansion = ValueExpansion(self.world.bank, config.dual.fixed_horizon)
        self._errors: list[float] = []

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        return act_model_free(self, obs, explore)

    def observe(self, transition: Transition) -> None:
        store_extrinsic(self, transition)

    def learn_minibatch(self) -> dict[str, float]:
        """Eq. 5 on the minibatch's latents, then the learner's update with the expanded target."""
        batch = to_device(self.replay.sample(self.config.agent.batch_size, self.rng), self.device)
        latents = self.learner.encode(torch.cat([batch.obs, batch.next_obs])).cpu()
        phi, next_phi = latents[: batch.obs.shape[0]], latents[batch.obs.shape[0]:]
        errors = self.world.learn_batch(phi, batch.action.cpu(), batch.reward_ext.cpu(), next_phi)
        self._errors.append(float(errors.mean()))
        self.updates += 1
        return self.learner.update(batch)

    def episode_diagnostics(self) -> dict[str, float]:
        out = learner_diagnostics(self.learner, self.steps, len(self.replay))
        out["dual/model_error"] = float(np.mean(self._errors)) if self._errors else math.nan
        out["dual/horizon"] = float(self.config.dual.fixed_horizon)
        self._errors = []
        return out

    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "dual": {"world": self.world.state_dict()}}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.world.load_state_dict(state["dual"]["world"])
