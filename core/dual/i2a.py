"""I2A, Integrated Imagination-Arbitration (Algorithm 3), as an agent of the shared trainer.

IM2C (``core.dual.im2c``) plus imagination: the learner also learns from imagined latent transitions. The
agent holds a learner (``agent.ac``), the pixel replay B_pixel, the dual system and its imagination
(`core.dual.imagination`: where imagined transitions come from, when a rollout stops, how deep; B_latent
lives there when the reading keeps one). One training step, in the box's order:

- ``act``: φ_t = f(s_t) (line 9); ITM update, node n (10-11); the meta-controller's decision (12-19, the
  model-based branch rolls out with the adaptive depth of Alg. 1); the imagination's act-time part (13-21: in
  the ``paper`` reading the rollout's H imagined transitions go to B_latent, line 17); the learner's
  exploration around the action (20).
- ``observe``: φ_{t+1}, then the dual system's lines 21-25 of Alg. 2: r_int, r = r_ext + r_int into B_pixel,
  one Eq. 5 step of M_n, R_n.
- ``update_after_step`` / ``update_after_episode``: lines 34-37, the learner's
  :meth:`~core.modelfree.learners.base.Learner.update` on a pixel minibatch and the imagination's latent one.

DDPG+LA-Imagination is this agent with model-free acting and LA-Imagination's rollout stop
(``core.dual.baselines``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from core.config import Config
from core.dual.dual_system import DualSystem, StepStart
from core.dual.imagination import RolloutStop, make_imagination
from core.dual.planning import TerminalValue
from core.envs.spec import EnvSpec
from core.modelfree.agent import LearnerAgent, Transition, learner_diagnostics, to_device
from core.modelfree.replay import PixelReplay


class I2A(LearnerAgent):
    """Algorithm 3 (module docstring); ``arbitration=False, stop="la"`` is DDPG+LA-Imagination."""

    def __init__(
        self,
        config: Config,
        spec: EnvSpec,
        rng: np.random.Generator,
        *,
        arbitration: bool = True,
        stop: RolloutStop = "reliable",
    ) -> None:
        super().__init__(config, spec, rng)  # the learner: lines 1-3
        latent_dim = self.learner.latent_dim
        # Line 5: B_pixel (``agent.buffer_size``, every method's real replay); B_latent is the imagination's.
        self.replay = PixelReplay(config.agent.buffer_size, spec.obs_shape, spec.action_dim, spec.obs_dtype)
        self.dual = DualSystem(config.dual, latent_dim, spec.action_dim, rng, self.encode_batch,  # lines 6-7
                               arbitration=arbitration,
                               value=TerminalValue(self.value_and_gradient, config.agent.gamma))
        self.imagination = make_imagination(self.dual, self.actor, rng, stop, self.encode_batch, latent_dim,
                                            spec.action_dim)
        self.start: StepStart | None = None
        """φ_t and n of the step in progress, from ``act`` to ``observe``."""

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        phi = self.encode(obs)  # line 9
        if not explore:
            return self.greedy(phi)
        self.start = self.dual.locate(phi)  # lines 10-11
        action, rollout = self.dual.decide(self.start, self.actor)  # lines 12-19
        self.imagination.after_decide(self.start, rollout)  # lines 13-21 (line 17)
        return self.explore(action, phi)  # line 20

    def observe(self, transition: Transition) -> None:
        next_phi = self.encode(transition.next_obs)  # line 21 of Alg. 2
        self.steps += 1
        self.dual.observe(self.start, next_phi, transition, self.replay, self.steps)  # lines 22-25 of Alg. 2
        self.start = None

    def learn_minibatch(self) -> dict[str, float]:
        """Lines 34-37 on a pixel minibatch and the imagination's latent one (module docstring)."""
        batch = self.replay.sample(self.config.agent.batch_size, self.rng)
        latent = self.imagination.minibatch(batch.obs)
        batch = to_device(batch, self.device)
        latent = None if latent is None else to_device(latent, self.device)
        self.updates += 1
        return self.learner.update(batch, latent)

    def episode_diagnostics(self) -> dict[str, float]:
        return {
            **learner_diagnostics(self.learner, self.steps, len(self.replay)),
            **self.dual.diagnostics(),
            **self.imagination.diagnostics(),
        }

    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "dual": self.dual.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.dual.load_state_dict(state["dual"])

    def replay_state_dict(self) -> dict[str, Any]:
        return {**super().replay_state_dict(), **self.imagination.replay_state_dict()}

    def load_replay_state_dict(self, state: dict[str, Any]) -> None:
        super().load_replay_state_dict(state)
        self.imagination.load_replay_state_dict(state)
