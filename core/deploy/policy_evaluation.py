"""``evaluate_policy``: the grasp-trial evaluator on the simulator for a policy file (``dualsys eval``, jobs);
for a policy of another gymnasium task, greedy episodes on that task (``episode_evaluation``).

The policy is a run directory or ``.pt`` checkpoint (run with PyTorch, or — ``onnx=True`` — exported to a
temporary ONNX file with the parity check and run with onnxruntime), or an ``.onnx`` file (always
onnxruntime). The :class:`SimRobot` gets the policy's hand mode (from the checkpoint's config or the ONNX
metadata), so its motor commands have the length the policy emits; ``domain`` picks the camera.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

from core.config import NICO_GRASP_ID, EnvConfig
from core.deploy.episode_evaluation import EpisodeReport, EpisodeResult, run_episodes
from core.deploy.grasp_trials import DEFAULT_TRIAL_SEED, PolicyFn, TrialReport, TrialResult, run_grasp_trials
from core.deploy.onnx_export import export_policy
from core.deploy.onnx_policy import OnnxPolicy
from core.deploy.robot import SimRobot
from core.envs import CameraShift
from core.runs.policy import load_policy

DOMAINS = ("sim", "real")


def load_deployable(
    policy_path: Path | str, *, onnx: bool = False, workdir: Path | None = None
) -> tuple[PolicyFn, EnvConfig]:
    """``(act, env)`` for a checkpoint/run directory (PyTorch, or exported to ONNX) or an ``.onnx`` file;
    ``env`` is the task the policy was trained on (NicoGrasp's ``hand`` and ``level``, or another id)."""
    path = Path(policy_path)
    if path.suffix == ".onnx":
        runner = OnnxPolicy(path)
        env = EnvConfig(
            id=runner.env_id,
            kwargs=runner.env_kwargs,
            success=runner.env_success,  # type: ignore[arg-type]
            hand=runner.hand,  # type: ignore[arg-type]
            level=runner.level,  # type: ignore[arg-type]
        )
        return runner.act, env
    policy = load_policy(path)
    if not onnx:
        return policy.act, policy.config.env
    if workdir is None:
        raise ValueError("exporting to ONNX for evaluation needs a working folder")
    report = export_policy(policy, out=workdir / "policy.onnx")
    return OnnxPolicy(report.path).act, policy.config.env


def evaluate_policy(
    *,
    policy_path: Path | str,
    trials: int = 25,
    max_steps: int = 8,
    domain: str = "sim",
    seed: int = DEFAULT_TRIAL_SEED,
    onnx: bool = False,
    camera_shift: CameraShift | None = None,
    on_trial: Callable[[TrialResult], None] | Callable[[EpisodeResult], None] | None = None,
) -> TrialReport | EpisodeReport:
    """Run ``trials`` grasp trials of at most ``max_steps`` steps on NicoGrasp seen through ``domain``; for a
    policy of another task, ``trials`` greedy episodes of that task (its own time limit; ``max_steps``,
    ``domain`` and ``camera_shift`` are NicoGrasp's)."""
    if domain not in DOMAINS:
        raise ValueError(f"unknown domain {domain!r} (choose from sim, real)")
    if trials < 1 or max_steps < 1:
        raise ValueError(f"trials and max_steps must be >= 1, got {trials} and {max_steps}")
    with tempfile.TemporaryDirectory(prefix="dualsys-eval-") as workdir:
        act, env = load_deployable(policy_path, onnx=onnx, workdir=Path(workdir))
        if env.id != NICO_GRASP_ID:
            return run_episodes(act, env, episodes=trials, seed=seed, on_episode=on_trial)  # type: ignore[arg-type]
        with SimRobot(domain=domain, camera_shift=camera_shift, hand=env.hand, level=env.level) as robot:
            return run_grasp_trials(
                act, robot, trials=trials, max_steps=max_steps, seed=seed, on_trial=on_trial
            )
