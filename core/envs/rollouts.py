"""Run a policy on NicoGrasp over seeded episodes and count outcomes (the oracle check and calibration)."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np

Policy = Callable[[gym.Env, dict], np.ndarray]
"""A policy of the env and its last `info` (the oracle reads `info`; trivial policies ignore both)."""


def rollout_rates(env: gym.Env, policy: Policy, episodes: int, seed: int = 0) -> dict[str, float]:
    """Success and topple rates and the mean episodic return of `policy` over `episodes` episodes, episode i
    reset with seed + i."""
    successes = toppled = steps = 0
    total_return = 0.0
    for episode in range(episodes):
        _, info = env.reset(seed=seed + episode)
        done = False
        while not done:
            _, reward, terminated, truncated, info = env.step(policy(env, info))
            total_return += float(reward)
            steps += 1
            done = terminated or truncated
        successes += int(info["success"])
        toppled += int(info["toppled"])
    return {
        "success": successes / episodes,
        "toppled": toppled / episodes,
        "mean_steps": steps / episodes,
        "mean_return": total_return / episodes,
    }
