"""IM2C, the Intrinsically Motivated Meta-Controller (Algorithm 2), as an agent of the shared trainer.

The agent holds its parts: a learner (``agent.ac``: DDPG by default, as the paper; CACLA, TD3, SAC), the pixel
replay B, and the dual system (regions, local world models M_n and R_n, learning progress, the
meta-controller; ``core.dual.dual_system``). One training step, in the box's order, over the trainer's hooks:

- ``act``: φ_t = f(s_t) (line 9); ITM update, node n (10-11); model-based action by gradient MPC over an
  adaptive-depth rollout when n is reliable, else μ(φ_t) (12-19); the learner's exploration around it (20).
- ``observe``: φ_{t+1} = f(s_{t+1}) (21); r_int from n's learning progress (22); r = r_ext + r_int (23) into B
  (24); one Eq. 5 step of M_n, R_n (25).
- ``update_after_step`` / ``update_after_episode``: the learner's update on a minibatch from B (26-28).

What the readings of each mechanism are (one ``dual`` field each, `core.dual.readings`) is in
docs/dual-system.md, "Mechanisms", with a table of the dual agents' readings: the ``default`` profile's
``repaired`` beside the ``paper`` profile's ``paper`` and ``released`` ones. DDPG+CMC is this agent over one
global region with a fixed horizon (``core.dual.baselines``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from core.config import Config
from core.dual.dual_system import DualSystem
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
                               regions=regions, fixed_horizon=fixed_horizon)

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        phi = self.encode(obs)  # line 9
        if not explore:
            return self.greedy(phi)
        node = self.dual.locate(phi)  # lines 10-11
        action, _ = self.dual.decide(phi, node, self.actor)  # lines 12-19
        return self.explore(action, phi)  # line 20

    def observe(self, transition: Transition) -> None:
        observe_real_step(self, self.dual, transition)  # lines 21-25

    def episode_diagnostics(self) -> dict[str, float]:
        return {**learner_diagnostics(self.learner, self.steps, len(self.replay)), **self.dual.diagnostics()}

    # update_after_step / update_after_episode (LearnerAgent): the learner's update, lines 26-28.

    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "dual": self.dual.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.dual.load_state_dict(state["dual"])


def observe_real_step(agent: LearnerAgent, dual: DualSystem, transition: Transition) -> None:
    """Algorithm 2 lines 21-25, the same in every dual agent: φ_{t+1} = f(s_{t+1}) (21); r_int and one Eq. 5
    step of M_n, R_n (22, 25); r = r_ext + r_int into the pixel replay (23-24); the refit repair when due."""
    next_phi = agent.encode(transition.next_obs)  # line 21
    r_int = dual.learn(next_phi, transition)  # lines 22 and 25
    agent.replay.add(transition.action, transition.reward + r_int, transition.next_obs,  # lines 23-24
                     transition.terminated, reward_ext=transition.reward)
    agent.steps += 1
    if dual.refit_due(agent.steps):
        refit_dual_system(agent, dual)


def refit_dual_system(agent: LearnerAgent, dual: DualSystem) -> None:
    """The refit repair (``DualSystem.refit``): ``dual.refit_batch`` replayed real transitions, re-encoded by
    the current encoder, one Eq. 5 step for each node they reach."""
    batch = agent.replay.sample(agent.config.dual.refit_batch, agent.rng)
    with torch.no_grad():
        latents = agent.learner.encode(torch.cat([batch.obs, batch.next_obs]).to(agent.device)).cpu()
    dual.refit(batch, latents)
