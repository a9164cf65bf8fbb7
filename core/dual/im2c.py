"""IM2C, the Intrinsically Motivated Meta-Controller (Algorithm 2), as an agent of the shared trainer.

The agent holds its parts: a learner (``agent.ac``: DDPG by default, as the paper; CACLA, TD3, SAC), the pixel
replay B, and the dual system (regions, local world models M_n and R_n, learning progress, the
meta-controller; ``core.dual.dual_system``). One training step, in the box's order, over the trainer's hooks:

- ``act``: φ_t = f(s_t) (line 9); ITM update, node n (10-11); model-based action by gradient MPC over an
  adaptive-depth rollout when n is reliable, else μ(φ_t) (12-19); the learner's exploration around it (20).
- ``observe``: φ_{t+1} = f(s_{t+1}) (21); then the dual system's lines 22-25 (`DualSystem.observe`): r_int
  from n's learning progress (22); r = r_ext + r_int (23) into B (24); one Eq. 5 step of M_n, R_n (25).
- ``update_after_step`` / ``update_after_episode``: the learner's update on a minibatch from B (26-28).

What the readings of each mechanism are (one ``dual`` field each, `core.dual.readings`) is in
docs/dual-system.md, "Mechanisms", with a table of the dual agents' readings: the ``default`` profile's
``repaired`` beside the ``paper`` profile's ``paper`` and ``released`` ones. DDPG+CMC is this agent over one
global region with a fixed horizon (``core.dual.baselines``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from core.config import Config
from core.dual.dual_system import DualSystem, StepStart
from core.dual.planning import TerminalValue
from core.envs.spec import EnvSpec
from core.modelfree.agent import LearnerAgent, Transition, learner_diagnostics
from core.modelfree.replay import PixelReplay


class IM2C(LearnerAgent):
    """Algorithm 2 (module docstring); ``regions=False, fixed_horizon=H`` is DDPG+CMC."""

    def __init__(
        self,
        config: Config,
        spec: EnvSpec,
        rng: np.random.Generator,
        *,
        regions: bool = True,
        fixed_horizon: int | None = None,
    ) -> None:
        super().__init__(config, spec, rng)  # the learner: lines 1-3
        agent = config.agent
        self.replay = PixelReplay(agent.buffer_size, spec.obs_shape, spec.action_dim, spec.obs_dtype)  # 4
        self.dual = DualSystem(config.dual, self.learner.latent_dim, spec.action_dim, rng,  # lines 5-6
                               self.encode_batch, regions=regions, fixed_horizon=fixed_horizon,
                               value=TerminalValue(self.value_and_gradient, agent.gamma))
        self.start: StepStart | None = None
        """φ_t and n of the step in progress, from ``act`` to ``observe``."""

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        phi = self.encode(obs)  # line 9
        if not explore:
            return self.greedy(phi)
        self.start = self.dual.locate(phi)  # lines 10-11
        action, _ = self.dual.decide(self.start, self.actor)  # lines 12-19
        return self.explore(action, phi)  # line 20

    def observe(self, transition: Transition) -> None:
        next_phi = self.encode(transition.next_obs)  # line 21
        self.steps += 1
        self.dual.observe(self.start, next_phi, transition, self.replay, self.steps)  # lines 22-25
        self.start = None

    def episode_diagnostics(self) -> dict[str, float]:
        return {**learner_diagnostics(self.learner, self.steps, len(self.replay)), **self.dual.diagnostics()}

    # update_after_step / update_after_episode (LearnerAgent): the learner's update, lines 26-28.

    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "dual": self.dual.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.dual.load_state_dict(state["dual"])
