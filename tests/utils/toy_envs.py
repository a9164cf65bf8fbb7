"""Small gymnasium envs for the any-task tests, registered under ``dualsys_test/...`` on import.

* ``ToyImageEnv`` — uint8 images of any shape (default 48×48×3; ``channel_first`` gives 3×48×48): a bright
  square moves with a 2-D action in [-1, 1]; reward −distance to the centre.
* ``RecordingPendulum`` — Pendulum-v1 (actions ±2) that records every action it executes.
* envs with spaces dualsys refuses: a Discrete action, an unbounded Box action, a MultiBinary observation.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.envs.classic_control.pendulum import PendulumEnv


class ToyImageEnv(gym.Env):
    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(self, size: int = 48, channel_first: bool = False, max_steps: int = 20) -> None:
        self.size, self.channel_first, self.max_steps = size, channel_first, max_steps
        shape = (3, size, size) if channel_first else (size, size, 3)
        self.observation_space = spaces.Box(0, 255, shape, np.uint8)
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.position = np.zeros(2)
        self.t = 0

    def _obs(self) -> np.ndarray:
        image = np.zeros((self.size, self.size, 3), np.uint8)
        row, col = ((self.position + 1) / 2 * (self.size - 4)).astype(int)
        image[row : row + 4, col : col + 4] = 255
        return np.moveaxis(image, -1, 0).copy() if self.channel_first else image

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.position = self.np_random.uniform(-1, 1, 2)
        self.t = 0
        return self._obs(), {}

    def step(self, action):
        self.position = np.clip(self.position + 0.2 * np.asarray(action, dtype=np.float64), -1, 1)
        self.t += 1
        distance = float(np.linalg.norm(self.position))
        return self._obs(), -distance, distance < 0.1, self.t >= self.max_steps, {"success": distance < 0.1}


class RecordingPendulum(PendulumEnv):
    """Pendulum-v1 whose executed actions are appended to ``RecordingPendulum.actions``."""

    actions: ClassVar[list[np.ndarray]] = []

    def step(self, u):
        RecordingPendulum.actions.append(np.array(u, dtype=np.float64).copy())
        return super().step(u)


class _SpaceEnv(gym.Env):
    def __init__(self, observation_space: spaces.Space, action_space: spaces.Space) -> None:
        self.observation_space, self.action_space = observation_space, action_space

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action):
        return self.observation_space.sample(), 0.0, False, True, {}


def discrete_action_env() -> gym.Env:
    return _SpaceEnv(spaces.Box(-1, 1, (3,), np.float32), spaces.Discrete(3))


def unbounded_action_env() -> gym.Env:
    return _SpaceEnv(spaces.Box(-1, 1, (3,), np.float32), spaces.Box(-np.inf, np.inf, (2,), np.float32))


def multibinary_observation_env() -> gym.Env:
    return _SpaceEnv(spaces.MultiBinary(4), spaces.Box(-1, 1, (1,), np.float32))


REFUSED = [
    ("Nope-v9", "unknown env id 'Nope-v9'"),
    ("dualsys_test/DiscreteAction-v0", "unsupported action space: Discrete(3)"),
    ("dualsys_test/UnboundedAction-v0", "unsupported action space: unbounded Box"),
    ("dualsys_test/MultiBinaryObs-v0", "unsupported observation space: MultiBinary(4)"),
]
"""Env ids dualsys cannot train on, and the start of the one-line error that says why."""

REGISTERED = {
    "dualsys_test/ToyImage-v0": (ToyImageEnv, 20),
    "dualsys_test/RecordingPendulum-v0": (RecordingPendulum, 200),
    "dualsys_test/DiscreteAction-v0": (discrete_action_env, 5),
    "dualsys_test/UnboundedAction-v0": (unbounded_action_env, 5),
    "dualsys_test/MultiBinaryObs-v0": (multibinary_observation_env, 5),
}
for _id, (_entry, _steps) in REGISTERED.items():
    if _id not in gym.registry:
        gym.register(id=_id, entry_point=_entry, max_episode_steps=_steps)
