"""ThreeRegions: a 2-D point among three regions whose dynamics are learnable, already trivial, or noise.

The controlled problem of the intrinsic-reward check (`core.dual.checks.intrinsic`, issue #19): learning-
progress motivation should prefer the region whose dynamics can still be learned over the region whose
dynamics are trivially known and over a "noisy TV" whose outcomes are random — the property that sets it
apart from prediction-error curiosity, which the noise captures.

Observation ``(x, y, z)`` (float32): the point's position in [−1, 1]² and a screen value z ∈ [−1, 1]. Action
``(a_x, a_y)`` ∈ [−1, 1]²: the point moves by ``speed · a`` (0.05; clipped to the square) in every region.
The region is the third of the square the point lands in, by x:

- ``trivial`` (x < −1/3): the screen keeps its value (nothing but the position changes);
- ``learnable`` (−1/3 ≤ x < 1/3): the screen shows ``sin(f·x + k·a_x) · cos(f·y − k·a_y)`` (f =
  ``frequency``, 2; k = ``action_gain``, 2), a deterministic function of where the point was and how it
  moved (the planner-aim check, `core.dual.checks.planner_aim`, uses f = k = 1: a function its local models
  learn within its budget);
- ``noise`` (x ≥ 1/3): the screen shows a uniform random value (the noisy TV).

``layout`` reorders the thirds (default trivial | learnable | noise; the planner-aim check puts the
learnable third at an edge, so that a goal at the map's centre is not the learnable third by geometry).
The extrinsic reward is always 0; ``info["region"]`` names the region of the new position. Episodes end by
truncation after ``max_steps`` steps; the start is uniform over the square. Registered as
``dualsys/ThreeRegions-v0`` (``core/envs/__init__.py``).

It is also study 3's noisy TV (issue 29): a method drawn to the noise spends its steps there, one that
explores covers the rest. The last step's ``info["episode_diagnostics"]`` measures both for the episode, and
the trainer writes them into metrics.csv (``core.runs.trainer``):

- ``env/noise_share`` — the share of the episode's steps that ended in the noise region;
- ``env/coverage_rest`` — the share of the cells of a ``COVERAGE_CELLS`` × ``COVERAGE_CELLS`` grid over the
  square, among those outside the noise region, that the episode visited (start included).
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

REGIONS = ("trivial", "learnable", "noise")
"""Region names, left to right."""


COVERAGE_CELLS = 15
"""Cells per axis of the grid ``env/coverage_rest`` counts (cell side 2/15 ≈ 2.7 steps at speed 0.05)."""

COLUMN_CENTRES = (np.arange(COVERAGE_CELLS) + 0.5) * 2.0 / COVERAGE_CELLS - 1.0
"""Horizontal position of each grid column's centre."""

REST_COLUMNS = int(np.sum(COLUMN_CENTRES < 1.0 / 3.0))
"""Grid columns whose centre lies outside the noise region under the default layout (x < 1/3): 10 of 15."""


def region_of(x: float | np.ndarray) -> np.ndarray:
    """Which third (0, 1, 2 left to right) horizontal position ``x`` lies in: the index into `REGIONS` of its
    region under the default layout (`ThreeRegionsEnv.region_at` for another)."""
    return np.digitize(np.asarray(x), [-1.0 / 3.0, 1.0 / 3.0])


class ThreeRegionsEnv(gym.Env):
    """See the module docstring."""

    metadata: ClassVar[dict] = {"render_modes": []}

    def __init__(self, max_steps: int = 200, speed: float = 0.05, frequency: float = 2.0,
                 action_gain: float = 2.0, layout: tuple[str, ...] = REGIONS) -> None:
        if sorted(layout) != sorted(REGIONS):
            raise ValueError(f"layout must order {REGIONS} left to right, got {layout}")
        self.layout = tuple(layout)
        """The regions' names left to right (default `REGIONS`' order)."""
        self._kinds = np.array([REGIONS.index(name) for name in self.layout])
        self._rest_columns = self.region_at(COLUMN_CENTRES) != REGIONS.index("noise")
        """The grid columns outside the noise region (`episode_diagnostics`)."""
        self.max_steps = int(max_steps)
        self.speed = float(speed)
        self.frequency = float(frequency)
        self.action_gain = float(action_gain)
        self.observation_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self._position = np.zeros(2)
        self._screen = 0.0
        self._steps = 0
        self._noise_steps = 0
        self._visited = np.zeros((COVERAGE_CELLS, COVERAGE_CELLS), dtype=bool)

    def _visit(self) -> None:
        cell = np.minimum(((self._position + 1.0) / 2.0 * COVERAGE_CELLS).astype(int), COVERAGE_CELLS - 1)
        self._visited[cell[0], cell[1]] = True

    def episode_diagnostics(self) -> dict[str, float]:
        """``env/noise_share`` and ``env/coverage_rest`` of the episode so far (module docstring)."""
        rest = self._visited[self._rest_columns]
        return {
            "env/noise_share": self._noise_steps / max(1, self._steps),
            "env/coverage_rest": float(rest.sum()) / rest.size,
        }

    def _start_position(self) -> np.ndarray:
        """An episode's start: uniform over the square (`core.envs.noisy_tv` starts elsewhere)."""
        return self.np_random.uniform(-1.0, 1.0, size=2)

    def _observation(self) -> np.ndarray:
        return np.array([*self._position, self._screen], dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self._position = self._start_position()
        self._screen = 0.0
        self._steps = self._noise_steps = 0
        self._visited[:] = False
        self._visit()
        return self._observation(), {"region": REGIONS[int(self.region_at(self._position[0]))]}

    def region_at(self, x: float | np.ndarray) -> np.ndarray:
        """Index into `REGIONS` of the region at horizontal position ``x`` under this env's ``layout``."""
        return self._kinds[region_of(x)]

    def transitions(self, starts: np.ndarray, screens: np.ndarray, actions: np.ndarray,
                    ) -> tuple[np.ndarray, np.ndarray]:
        """The dynamics of the module docstring for a batch: new positions ``[N, 2]`` and screens ``[N]`` from
        positions ``starts [N, 2]``, screens ``[N]`` and actions ``[N, 2]`` (noise drawn from the env's
        generator). `step` moves the point with it; checks use it to build test transitions."""
        move = np.clip(np.asarray(actions, dtype=np.float64).reshape(-1, 2), -1.0, 1.0)
        starts = np.asarray(starts, dtype=np.float64).reshape(-1, 2)
        positions = np.clip(starts + self.speed * move, -1.0, 1.0)
        regions = self.region_at(positions[:, 0])
        new = np.array(screens, dtype=np.float64).reshape(-1)
        f, k = self.frequency, self.action_gain
        learnable = regions == REGIONS.index("learnable")
        new[learnable] = (np.sin(f * starts[learnable, 0] + k * move[learnable, 0])
                          * np.cos(f * starts[learnable, 1] - k * move[learnable, 1]))
        noise = regions == REGIONS.index("noise")
        new[noise] = self.np_random.uniform(-1.0, 1.0, size=int(noise.sum()))
        return positions, new

    def step(self, action: np.ndarray):
        positions, screens = self.transitions(self._position, np.array([self._screen]), action)
        self._position, self._screen = positions[0], float(screens[0])
        region = int(self.region_at(self._position[0]))
        self._steps += 1
        self._noise_steps += int(region == REGIONS.index("noise"))
        self._visit()
        truncated = self._steps >= self.max_steps
        info: dict[str, Any] = {"region": REGIONS[region]}
        if truncated:
            info["episode_diagnostics"] = self.episode_diagnostics()
        return self._observation(), 0.0, False, truncated, info
