"""Greedy episodes of a deployable policy on its own gymnasium task (``dualsys eval`` for tasks other than
NicoGrasp, whose evaluator is the 8-step grasp-trial protocol of ``grasp_trials``).

The policy answers in the env's units (its last layer maps [-1, 1] to the bounds), so the env is built
without the trainer's action rescaling; actions are clipped to the bounds. Episode k resets with
``seed + k``; an episode lasts until the env terminates or truncates (its own time limit). Success is the
training run's ``env.success`` rule; the report adds the mean return, which is what such tasks publish.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from core.config import EnvConfig
from core.deploy.grasp_trials import PolicyFn, wilson_interval
from core.envs.gym_env import episode_success, make_env


@dataclass(frozen=True)
class EpisodeResult:
    """One greedy episode."""

    episode: int
    seed: int
    success: bool
    steps: int
    episode_return: float


@dataclass(frozen=True)
class EpisodeReport:
    """All episodes: success rate with its 95% Wilson interval, mean and per-episode return."""

    trials: int
    successes: int
    success_rate: float
    ci_low: float
    ci_high: float
    mean_return: float
    per_trial: list[EpisodeResult] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "trials": self.trials,
            "successes": self.successes,
            "success_rate": self.success_rate,
            "ci_low": self.ci_low,
            "ci_high": self.ci_high,
            "mean_return": self.mean_return,
            "per_trial": [vars(result) for result in self.per_trial],
        }


def run_episodes(
    policy: PolicyFn,
    env_config: EnvConfig,
    *,
    episodes: int,
    seed: int,
    on_episode: Callable[[EpisodeResult], None] | None = None,
) -> EpisodeReport:
    """``episodes`` greedy episodes of ``policy`` on ``env_config``'s task (see the module docstring)."""
    adapted = make_env(env_config, evaluation=True, rescale_actions=False)
    env = adapted.env
    low, high = adapted.spec.bounds()
    results = []
    try:
        for k in range(episodes):
            obs, _ = env.reset(seed=seed + k)
            total, steps = 0.0, 0
            while True:
                action = np.asarray(policy(np.asarray(obs)[None]), dtype=np.float32).reshape(-1)
                obs, reward, terminated, truncated, info = env.step(np.clip(action, low, high))
                total += float(reward)
                steps += 1
                if terminated or truncated:
                    break
            result = EpisodeResult(
                episode=k,
                seed=seed + k,
                success=episode_success(info, terminated, truncated, env_config.success),
                steps=steps,
                episode_return=total,
            )
            results.append(result)
            if on_episode is not None:
                on_episode(result)
    finally:
        env.close()
    successes = sum(r.success for r in results)
    ci_low, ci_high = wilson_interval(successes, episodes)
    return EpisodeReport(
        trials=episodes,
        successes=successes,
        success_rate=successes / episodes,
        ci_low=ci_low,
        ci_high=ci_high,
        mean_return=float(np.mean([r.episode_return for r in results])),
        per_trial=results,
    )
