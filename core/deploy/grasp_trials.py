"""The grasp-trial evaluator of Section 4.2 (the Table 2 protocol), against any :class:`Robot`.

One trial: ``robot.place_object(seed + k)`` puts the object at a graspable position and the arm at its start
pose; then up to ``max_steps`` (8) consecutive grasp steps, each "take an image → policy → motor command →
execute". The trial succeeds as soon as ``robot.verify_grasp()`` confirms a grasp; it fails when the object
is knocked over or after ``max_steps`` steps without a verified grasp. The next trial places the object
again. The success rate is reported with its 95% Wilson score interval (:func:`wilson_interval`).

The policy is any callable ``uint8 [N, 32, 64, 3] → actions [N, action_dim]``: ``runs.policy.Policy.act``,
``core.deploy.OnnxPolicy.act``, or a scripted policy in tests.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from core.deploy.robot import Robot

PolicyFn = Callable[[np.ndarray], np.ndarray]
"""uint8 images ``[N, H, W, 3]`` → actions ``[N, action_dim]``."""

DEFAULT_TRIAL_SEED = 500_000
"""Trial k places the object with seed DEFAULT_TRIAL_SEED + k by default: disjoint from the training env's
seed and from the trainer's evaluation seeds (1 000 000 + k), on which ``best.pt`` was selected."""

WILSON_Z95 = 1.959963984540054
"""Standard-normal quantile of 0.975."""


def wilson_interval(successes: int, trials: int, z: float = WILSON_Z95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion p̂ = successes / trials:

    (p̂ + z²/2n ± z·sqrt(p̂(1−p̂)/n + z²/4n²)) / (1 + z²/n).
    """
    if trials < 1:
        raise ValueError(f"trials must be >= 1, got {trials}")
    if not 0 <= successes <= trials:
        raise ValueError(f"successes must lie in [0, {trials}], got {successes}")
    p = successes / trials
    z2 = z * z
    denominator = 1.0 + z2 / trials
    centre = (p + z2 / (2 * trials)) / denominator
    half = z * math.sqrt(p * (1.0 - p) / trials + z2 / (4 * trials * trials)) / denominator
    low = 0.0 if successes == 0 else max(0.0, centre - half)  # exact at the ends (rounding aside)
    high = 1.0 if successes == trials else min(1.0, centre + half)
    return low, high


@dataclass(frozen=True)
class TrialResult:
    """One grasp trial."""

    trial: int
    seed: int
    success: bool
    steps: int
    """Grasp steps executed (1..max_steps)."""
    outcome: str
    """``grasped``, ``toppled`` or ``step limit``."""
    grasp_attempts: int


@dataclass(frozen=True)
class TrialReport:
    """All trials: counts, success rate and its 95% Wilson interval."""

    trials: int
    successes: int
    success_rate: float
    ci_low: float
    ci_high: float
    max_steps: int
    per_trial: list[TrialResult] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """``{"trials", "successes", "success_rate", "ci_low", "ci_high", "max_steps", "per_trial"}``."""
        return {"trials": self.trials, "successes": self.successes, "success_rate": self.success_rate,
                "ci_low": self.ci_low, "ci_high": self.ci_high, "max_steps": self.max_steps,
                "per_trial": [asdict(t) for t in self.per_trial]}


def run_trial(policy: PolicyFn, robot: Robot, *, trial: int, seed: int, max_steps: int) -> TrialResult:
    """One trial of the Section 4.2 protocol (see the module docstring)."""
    robot.place_object(seed)
    attempts = 0
    for step in range(1, max_steps + 1):
        image = np.asarray(robot.capture_image())
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(f"robot.capture_image must return a uint8 [H, W, 3] image, got "
                             f"{image.dtype} {list(image.shape)}")
        action = np.asarray(policy(image[None]), dtype=np.float32).reshape(-1)
        if action.shape != (robot.action_dim,):
            raise ValueError(f"the policy returns {action.shape[0]}-d actions but the robot takes "
                             f"{robot.action_dim}-d motor commands (hand mode mismatch?)")
        result = robot.execute(np.clip(action, -1.0, 1.0))
        attempts += int(result.grasp_attempted)
        if robot.verify_grasp():
            return TrialResult(trial, seed, True, step, "grasped", attempts)
        if result.toppled:
            return TrialResult(trial, seed, False, step, "toppled", attempts)
    return TrialResult(trial, seed, False, max_steps, "step limit", attempts)


def run_grasp_trials(
    policy: PolicyFn,
    robot: Robot,
    *,
    trials: int = 25,
    max_steps: int = 8,
    seed: int = DEFAULT_TRIAL_SEED,
    on_trial: Callable[[TrialResult], None] | None = None,
) -> TrialReport:
    """``trials`` grasp trials (trial k placed with ``seed + k``); Section 4.2 uses 25 trials of ≤ 8 steps."""
    if trials < 1:
        raise ValueError(f"trials must be >= 1, got {trials}")
    if max_steps < 1:
        raise ValueError(f"max_steps must be >= 1, got {max_steps}")
    results: list[TrialResult] = []
    for k in range(trials):
        result = run_trial(policy, robot, trial=k + 1, seed=seed + k, max_steps=max_steps)
        results.append(result)
        if on_trial is not None:
            on_trial(result)
    successes = sum(r.success for r in results)
    low, high = wilson_interval(successes, trials)
    return TrialReport(trials=trials, successes=successes, success_rate=successes / trials, ci_low=low,
                       ci_high=high, max_steps=max_steps, per_trial=results)
