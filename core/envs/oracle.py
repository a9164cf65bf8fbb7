"""A scripted oracle for NicoGrasp.

It reads `info`, turns the shoulder to the glass, and closes the hand if the hand is learned.

It exists to prove the task solvable and grasp verification right (tests, `dualsys env check`); no learner
uses it.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from core.envs.rollouts import rollout_rates


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
    rates = rollout_rates(env, oracle_action, episodes, seed)
    return {
        "oracle_success_rate": rates["success"],
        "episodes": episodes,
        "toppled": round(rates["toppled"] * episodes),
        "mean_steps": rates["mean_steps"],
    }
