"""Calibration of any gymnasium task by trivial policies: a uniform random policy and constant actions.

The counterpart of ``calibration`` (NicoGrasp's levels) for a task a user brings: before any learner runs,
say what needs no learning. Actions are the agents' normalised ones (the env is wrapped by
``gym_env.make_env``, so [-1, 1] maps onto its bounds); the constants are a grid of −1, −0.5, 0, 0.5, 1
per dimension (every combination up to 3 dimensions, else the same value on every dimension). Success is
``env.success``'s rule; the best constant is the one with the highest success rate, then mean return.
There is no oracle for an arbitrary task (``"oracle": null``).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator

import numpy as np

from core.config import EnvConfig
from core.envs.gym_env import episode_success, make_env

CONSTANT_GRID = (-1.0, -0.5, 0.0, 0.5, 1.0)
"""Values of each action dimension in the constant policies (normalised units)."""

FULL_GRID_MAX_DIM = 3
"""Up to this many action dimensions every combination of ``CONSTANT_GRID`` is tried (5³ = 125)."""

ActionFn = Callable[[int], np.ndarray]
"""A trivial policy: the action at an episode's step t (it never looks at the observation)."""


def constant_actions(action_dim: int) -> Iterator[tuple[float, ...]]:
    """The constant actions tried for an ``action_dim``-dimensional task (see the module docstring)."""
    if action_dim <= FULL_GRID_MAX_DIM:
        yield from itertools.product(CONSTANT_GRID, repeat=action_dim)
    else:
        for value in CONSTANT_GRID:
            yield (value,) * action_dim


def constant_count(action_dim: int) -> int:
    return sum(1 for _ in constant_actions(action_dim))


def rollout_returns(env_config: EnvConfig, act: ActionFn, episodes: int, seed: int) -> dict[str, float]:
    """Success rate, mean return and mean length of ``act`` over ``episodes`` episodes (episode i: seed+i)."""
    adapted = make_env(env_config, evaluation=True)
    env = adapted.env
    successes, returns, lengths = 0, [], []
    try:
        for episode in range(episodes):
            env.reset(seed=seed + episode)
            total, step = 0.0, 0
            while True:
                _, reward, terminated, truncated, info = env.step(act(step))
                total += float(reward)
                step += 1
                if terminated or truncated:
                    break
            successes += int(episode_success(info, terminated, truncated, env_config.success))
            returns.append(total)
            lengths.append(step)
    finally:
        env.close()
    return {
        "success": successes / episodes,
        "mean_return": float(np.mean(returns)),
        "mean_steps": float(np.mean(lengths)),
    }


def calibrate_task(
    env_config: EnvConfig,
    episodes: int = 20,
    seed: int = 0,
    on_policy_done: Callable[[str], None] | None = None,
) -> dict:
    """``{"env", "episodes", "action_dim", "oracle": None, "random", "best_constant", "constants"}``."""
    probe = make_env(env_config)
    action_dim = probe.spec.action_dim
    probe.env.close()
    tick = on_policy_done or (lambda name: None)
    rng = np.random.default_rng(seed)
    random = rollout_returns(
        env_config,
        lambda step: rng.uniform(-1.0, 1.0, action_dim).astype(np.float32),
        episodes,
        seed,
    )
    tick("random")
    rows = []
    for action in constant_actions(action_dim):
        fixed = np.asarray(action, dtype=np.float32)
        rates = rollout_returns(env_config, lambda step, a=fixed: a, episodes, seed)
        rows.append({"action": list(action), **rates})
        tick(f"constant {list(action)}")
    best = max(rows, key=lambda row: (row["success"], row["mean_return"]))
    return {
        "env": env_config.id,
        "episodes": episodes,
        "action_dim": action_dim,
        "oracle": None,
        "random": random,
        "best_constant": dict(best),
        "constants": rows,
    }
