"""Calibration of a task level by trivial policies: what the scripted oracle, a uniform random policy and
every constant action achieve (docs/environment.md, "Task levels").

A level is judged only by these: the oracle proves it solvable; random and constant actions show how much of
it needs no learning (a constant needs no camera at all). Nothing here looks at a learner.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from core.envs.nico_grasp import NicoGraspEnv
from core.envs.oracle import oracle_action
from core.envs.rollouts import Policy, rollout_rates

CONSTANT_SHOULDER_GRID = tuple(round(-1.0 + 0.1 * i, 1) for i in range(21))
"""Shoulder values of the constant actions: −1 to 1 in steps of 0.1."""


def random_policy(seed: int) -> Policy:
    """Uniform random actions over the action space, from its own seeded generator."""
    rng = np.random.default_rng(seed)

    def act(env: NicoGraspEnv, info: dict) -> np.ndarray:
        return rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)

    return act


def constant_policy(action: tuple[float, ...]) -> Policy:
    fixed = np.asarray(action, dtype=np.float32)
    return lambda env, info: fixed


def constant_actions(hand: str) -> Iterator[tuple[float, ...]]:
    """Constant actions: each shoulder value; with the learned hand, each with close (+1) and open (−1)."""
    for shoulder in CONSTANT_SHOULDER_GRID:
        if hand == "auto":
            yield (shoulder,)
        else:
            yield (shoulder, 1.0)
            yield (shoulder, -1.0)


def calibrate(
    level: str,
    reward: str = "sparse",
    episodes: int = 100,
    hand: str | None = None,
    seed: int = 0,
    constants: tuple[tuple[float, ...], ...] | None = None,
    on_policy_done: Callable[[str], None] | None = None,
) -> dict:
    """The calibration of one level (issue 9's JSON contract).

    Returns ``{"level", "reward", "hand", "episodes", "oracle": {...}, "random": {...}, "best_constant":
    {"action", "success", "toppled"}, "constants": [...]}``; each policy is run on the same seeded glass
    positions. `constants` narrows the grid (tests); `on_policy_done` is called after each policy (progress).
    """
    env = NicoGraspEnv(level=level, hand=hand, reward_mode=reward)
    try:
        tick = on_policy_done or (lambda name: None)
        oracle = rollout_rates(env, oracle_action, episodes, seed)
        tick("oracle")
        random = rollout_rates(env, random_policy(seed), episodes, seed)
        tick("random")
        rows = []
        for action in constants if constants is not None else tuple(constant_actions(env.hand)):
            rates = rollout_rates(env, constant_policy(action), episodes, seed)
            rows.append({"action": list(action), **rates})
            tick(f"constant {list(action)}")
        best = max(rows, key=lambda row: (row["success"], -row["toppled"]))
        return {
            "level": level,
            "reward": reward,
            "hand": env.hand,
            "episodes": episodes,
            "oracle": oracle,
            "random": random,
            "best_constant": dict(best),
            "constants": rows,
        }
    finally:
        env.close()


def constant_count(hand: str) -> int:
    """How many constant actions `calibrate` runs for a hand (for progress totals)."""
    return sum(1 for _ in constant_actions(hand))
