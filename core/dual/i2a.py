"""I2A, Integrated Imagination-Arbitration (Algorithm 3), as an agent of the shared trainer.

IM2C (``core.dual.im2c``) plus imagination: the learner also learns from imagined latent transitions. The
agent holds a learner (``agent.ac``), the pixel replay B_pixel, the latent replay B_latent and the dual
system. One training step, in the box's order:

- ``act``: φ_t = f(s_t) (line 9); ITM update, node n (10-11); the meta-controller's decision (12-19,
  the model-based branch rolls out with the adaptive depth of Alg. 1 and, in the paper's reading, stores the
  rollout's H imagined transitions in B_latent, line 17); the learner's exploration around the action (20).
- ``observe``: φ_{t+1}, r_int, r = r_ext + r_int into B_pixel, one Eq. 5 step of M_n, R_n (21-25 of Alg. 2).
- ``update_after_step`` / ``update_after_episode``: lines 34-37, the learner's
  :meth:`~core.modelfree.learners.base.Learner.update_with_imagination` on a pixel minibatch and a latent one.

Where the latent minibatch comes from is ``dual.imagination`` (`core.dual.readings.Imagination`): the
act-time rollouts (``paper``: B_latent, filled at line 17) or learn-time ones (``repaired``: rollouts from
the pixel minibatch's states, encoded by the current encoder, made at each update and never stored;
``core.dual.imagination.imagine``). DDPG+LA-Imagination
is this agent with model-free acting and LA-Imagination's rollouts (``core.dual.baselines``).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import torch

from core.config import Config
from core.dual.dual_system import DualSystem
from core.dual.im2c import observe_real_step
from core.dual.imagination import RegionModels, imagine, la_imagination_rollout
from core.envs.spec import EnvSpec
from core.modelfree.agent import LearnerAgent, Transition, learner_diagnostics, to_device
from core.modelfree.replay import LatentBatch, LatentReplay, PixelReplay

Imagination = Literal["adaptive", "la"]
"""The imagined rollouts: Alg. 1's adaptive rollout (I2A) or LA-Imagination's error-driven one."""


class I2A(LearnerAgent):
    """Algorithm 3 (module docstring); ``arbitration=False, imagination="la"`` is DDPG+LA-Imagination."""

    def __init__(
        self,
        config: Config,
        spec: EnvSpec,
        rng: np.random.Generator,
        *,
        arbitration: bool = True,
        imagination: Imagination = "adaptive",
    ) -> None:
        super().__init__(config, spec, rng)  # the learner: lines 1-3
        dual = config.dual
        self.dual = DualSystem(dual, self.learner.latent_dim, spec.action_dim, rng,  # lines 6-7
                               arbitration=arbitration)
        # Line 5: B_pixel (60k in the paper) beside B_latent (200k).
        self.replay = PixelReplay(dual.pixel_buffer_size, spec.obs_shape, spec.action_dim, spec.obs_dtype)
        self.latent_replay = LatentReplay(dual.latent_buffer_size, self.learner.latent_dim, spec.action_dim)
        self.imagination: Imagination = imagination
        self.act_time = self.dual.world.readings.imagination.source == "act_time"

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        phi = self.encode(obs)  # line 9
        if not explore:
            return self.greedy(phi)
        node = self.dual.locate(phi)  # lines 10-11
        action, rollout = self.dual.decide(phi, node, self.actor)  # lines 12-19
        if self.act_time and self.imagination == "adaptive":
            self.dual.store_imagined(rollout, self.latent_replay)  # line 17
        if self.act_time and self.imagination == "la":
            dual = self.config.dual
            rollout = la_imagination_rollout(phi, node, self.dual.world, self.actor, dual.d_max,
                                             dual.imagination_prob_scale, self.rng)
            self.dual.store_imagined(rollout, self.latent_replay)
        return self.explore(action, phi)  # line 20

    def observe(self, transition: Transition) -> None:
        observe_real_step(self, self.dual, transition)  # lines 21-25 of Alg. 2

    def learn_minibatch(self) -> dict[str, float]:
        """Lines 34-37 on a pixel minibatch and a latent one (module docstring)."""
        batch = self.replay.sample(self.config.agent.batch_size, self.rng)
        latent = None
        if not self.act_time:
            latent = self._imagine_from(batch.obs)
        elif len(self.latent_replay) > 0:
            latent = self.latent_replay.sample(self.config.dual.latent_batch_size, self.rng)
        batch = to_device(batch, self.device)
        latent = None if latent is None else to_device(latent, self.device)
        self.updates += 1
        return self.learner.update_with_imagination(batch, latent)

    def _imagine_from(self, obs: torch.Tensor) -> LatentBatch | None:
        """Learn-time imagination: rollouts from the minibatch's states, encoded by the current encoder, at
        most ``dual.imagination_depth`` (default D_max) model steps long."""
        dual = self.config.dual
        with torch.no_grad():
            phi = self.learner.encode(obs.to(self.device)).cpu()
        stop = "reliable" if self.imagination == "adaptive" else "la"
        model = RegionModels(self.dual.world, self.rng, stop=stop, la_scale=dual.imagination_prob_scale)
        depth = dual.d_max if dual.imagination_depth is None else dual.imagination_depth
        latent = imagine(phi, model, self.actor, depth, self.rng, dual.latent_batch_size)
        self.dual.count_imagined(0 if latent is None else latent.latent.shape[0])
        return latent

    def episode_diagnostics(self) -> dict[str, float]:
        return {
            **learner_diagnostics(self.learner, self.steps, len(self.replay)),
            **self.dual.diagnostics(),
            "charts/latent_replay_size": float(len(self.latent_replay)),
        }

    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "dual": self.dual.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.dual.load_state_dict(state["dual"])

    def replay_state_dict(self) -> dict[str, Any]:
        return {**super().replay_state_dict(), "latent": self.latent_replay.state_dict()}

    def load_replay_state_dict(self, state: dict[str, Any]) -> None:
        super().load_replay_state_dict(state)
        self.latent_replay.load_state_dict(state["latent"])

