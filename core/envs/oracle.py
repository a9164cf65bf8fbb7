"""A scripted oracle for NicoGrasp.

It reads `info`, turns the shoulder to the glass, and closes the hand if the hand is learned.

It exists to prove the task solvable and grasp verification right (tests, `dualsys env check`); no learner
uses it.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np


def oracle_action(env: gym.Env, info: dict | None = None) -> np.ndarray:
    """The oracle's action for the env's current state, from `info` (default: the env's last info)."""
    base = env.unwrapped
    info = base.last_info if info is None else info
    step_deg = np.degrees(base.step_rad)
    delta = info["grasp_angle_deg"] - info["shoulder_deg"]
    shoulder = float(np.clip(delta / step_deg, -1.0, 1.0))
    if base.hand == "auto":
        return np.array([shoulder], dtype=np.float32)
    # Learned hand: close in the same step as the final approach (the move happens before the attempt).
    close = 1.0 if abs(delta) <= step_deg else -1.0
    return np.array([shoulder, close], dtype=np.float32)


def run_oracle(env: gym.Env, episodes: int, seed: int = 0) -> dict:
    """Run the oracle for `episodes` seeded episodes; returns the success rate and outcome counts."""
    successes = toppled = 0
    steps = 0
    for episode in range(episodes):
        _, info = env.reset(seed=seed + episode)
        done = False
        while not done:
            _, _, terminated, truncated, info = env.step(oracle_action(env, info))
            steps += 1
            done = terminated or truncated
        successes += int(info["success"])
        toppled += int(info["toppled"])
    return {
        "oracle_success_rate": successes / episodes,
        "episodes": episodes,
        "toppled": toppled,
        "mean_steps": steps / episodes,
    }
