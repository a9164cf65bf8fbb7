"""Check: the intrinsic reward steers toward what can be learned (Alg. 2 line 22; ``dual.intrinsic``,
``dual.intrinsic_scale``).

Purpose (Section 2.3.1: "this reward encourages actions that result in ..." data that improves the model):
a learning-progress reward should draw the agent to the region whose dynamics it can still learn — not to a
region it already predicts (nothing left to learn) and not to a "noisy TV" whose outcomes are random, which
captures prediction-error curiosity. The controlled problem is `core.envs.three_regions.ThreeRegionsEnv`
(``dualsys/ThreeRegions-v0``): the same point moves through a trivial, a learnable and a noise third.

The dual-system machinery is the agents' own: a `LocalWorldModels` built from the profile's dual section sees
φ = the observation (the encoder is the identity), ``observe_state`` and ``learn_transition`` run on every
real step, and the reward is ``TransitionFeedback.intrinsic_reward`` — the r_int the agents add to r_ext. Only
the learner is simple (`RegionSeeker`): an 8×8 grid over the square keeps a running mean of the r_int
received on entering each cell, value iteration over the grid's neighbour moves turns it into values, and
the point heads for the best neighbouring cell (10 % random moves). With r_int = 0 every value is 0 and it
walks at random: the baseline share.

Figures: the share of steps the point spends in each region over the second half of the run (after the
models and the learner have had the first half), averaged over seeds; the same without r_int.
"""

from __future__ import annotations

import numpy as np
import torch

from core.config import DualConfig
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels
from core.envs.three_regions import REGIONS, ThreeRegionsEnv, region_of

_MOVES = tuple((dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0))


class RegionSeeker:
    """The simple learner: running mean reward per grid cell, value iteration, head for the best neighbour."""

    def __init__(self, rng: np.random.Generator, grid: int = 8, gamma: float = 0.9, rate: float = 0.05,
                 explore: float = 0.1, replan_every: int = 50) -> None:
        self.rng, self.grid, self.gamma, self.rate = rng, grid, gamma, rate
        self.explore, self.replan_every = explore, replan_every
        self.reward = np.zeros((grid, grid))
        self.value = np.zeros((grid, grid))
        self.centres = (np.arange(grid) + 0.5) / grid * 2.0 - 1.0
        self.steps = 0

    def cell(self, position: np.ndarray) -> tuple[int, int]:
        index = np.clip(((position[:2] + 1.0) / 2.0 * self.grid).astype(int), 0, self.grid - 1)
        return int(index[0]), int(index[1])

    def _plan(self) -> None:
        g = self.grid
        value = self.value
        for _ in range(30):
            padded = np.pad(value, 1, constant_values=-np.inf)
            best = np.max([padded[1 + dx:1 + dx + g, 1 + dy:1 + dy + g] for dx, dy in _MOVES], axis=0)
            value = self.reward + self.gamma * np.maximum(best, value)
        self.value = value

    def act(self, observation: np.ndarray) -> np.ndarray:
        if self.steps % self.replan_every == 0:
            self._plan()
        self.steps += 1
        if self.rng.random() < self.explore:
            angle = self.rng.uniform(0.0, 2.0 * np.pi)
            return np.array([np.cos(angle), np.sin(angle)], dtype=np.float32)
        i, j = self.cell(observation)
        g = self.grid
        options = [(i + dx, j + dy) for dx, dy in _MOVES if 0 <= i + dx < g and 0 <= j + dy < g]
        values = np.array([self.value[c] for c in options])
        best = [c for c, v in zip(options, values, strict=True) if v == values.max()]
        if values.max() < self.value[i, j]:
            best = [(i, j)]
        target_cell = best[int(self.rng.integers(len(best)))]
        target = np.array([self.centres[target_cell[0]], self.centres[target_cell[1]]])
        if target_cell == (i, j):
            target = observation[:2] + self.rng.normal(0.0, 0.5, size=2)
        direction = target - observation[:2]
        return (direction / (np.linalg.norm(direction) + 1e-9)).astype(np.float32)

    def learn(self, next_observation: np.ndarray, reward: float) -> None:
        i, j = self.cell(next_observation)
        self.reward[i, j] += self.rate * (reward - self.reward[i, j])


def region_shares(dual: DualConfig, steps: int, seed: int, intrinsic: bool = True) -> np.ndarray:
    """Share of the second half's steps in each of `REGIONS`, with the configured r_int or without any."""
    rng = np.random.default_rng(seed)
    env = ThreeRegionsEnv()
    world = LocalWorldModels(dual, 3, 2, generator=torch.Generator().manual_seed(seed),
                                     readings=resolve(dual)) if intrinsic else None
    learner = RegionSeeker(rng)
    observation, _ = env.reset(seed=seed)
    visits = np.zeros(steps, dtype=np.int64)
    for step in range(steps):
        action = learner.act(observation)
        next_observation, _, _, truncated, _ = env.step(action)
        reward = 0.0
        if world is not None:
            phi = torch.from_numpy(observation)
            node = world.observe_state(phi)
            feedback = world.learn_transition(node, phi, torch.from_numpy(action), 0.0,
                                              torch.from_numpy(next_observation))
            reward = feedback.intrinsic_reward
        learner.learn(next_observation, reward)
        visits[step] = region_of(next_observation[0])
        observation = next_observation
        if truncated:
            observation, _ = env.reset()
    second_half = visits[steps // 2:]
    return np.array([np.mean(second_half == k) for k in range(len(REGIONS))])


def intrinsic_check(dual: DualConfig, steps: int = 6000, seeds: int = 5) -> dict[str, float]:
    """The JSON figures: shares of the learnable, learned (trivial) and noise regions, and the learnable share
    of the same learner without r_int (means over seeds)."""
    with_rint = np.mean([region_shares(dual, steps, seed) for seed in range(seeds)], axis=0)
    without = np.mean([region_shares(dual, steps, seed, intrinsic=False) for seed in range(seeds)], axis=0)
    trivial, learnable, noise = (REGIONS.index(name) for name in ("trivial", "learnable", "noise"))
    return {
        "learnable_share": round(float(with_rint[learnable]), 3),
        "learned_share": round(float(with_rint[trivial]), 3),
        "noise_share": round(float(with_rint[noise]), 3),
        "learnable_share_without_rint": round(float(without[learnable]), 3),
    }
