"""Deployment (Section 4.2): the ``Robot`` protocol and ``SimRobot``, the 8-step grasp-trial evaluator with a
Wilson 95% interval, ONNX export of encoder + actor checked against PyTorch, and ONNX inference.

Plain functions with keyword arguments for the CLI and the job service: ``export_onnx(policy_path=, out=)``,
``evaluate_policy(policy_path=, trials=, max_steps=, domain=, seed=, onnx=)`` (see docs/deployment.md).
"""

from core.deploy.env_images import PairedStates, render_env_images, render_paired_states
from core.deploy.grasp_trials import (
    DEFAULT_TRIAL_SEED,
    PolicyFn,
    TrialReport,
    TrialResult,
    run_grasp_trials,
    run_trial,
    wilson_interval,
)
from core.deploy.onnx_export import (
    ExportReport,
    OnnxExportError,
    OnnxParityError,
    check_onnx_parity,
    export_onnx,
    export_policy,
)
from core.deploy.onnx_policy import OnnxPolicy, OnnxPolicyError
from core.deploy.policy_evaluation import evaluate_policy, load_deployable
from core.deploy.robot import MotorResult, Robot, SimRobot

__all__ = [
    "DEFAULT_TRIAL_SEED",
    "ExportReport",
    "MotorResult",
    "OnnxExportError",
    "OnnxParityError",
    "OnnxPolicy",
    "OnnxPolicyError",
    "PairedStates",
    "PolicyFn",
    "Robot",
    "SimRobot",
    "TrialReport",
    "TrialResult",
    "check_onnx_parity",
    "evaluate_policy",
    "export_onnx",
    "export_policy",
    "load_deployable",
    "render_env_images",
    "render_paired_states",
    "run_grasp_trials",
    "run_trial",
    "wilson_interval",
]
