"""The table of job kinds the service runs."""

from __future__ import annotations

from pathlib import Path

from service.execution.job_kinds.base import JobKind, after_nothing
from service.execution.job_kinds.deployment import (
    attach_onnx,
    prepare_align,
    register_aligned,
    run_align,
    run_eval,
    run_export,
)
from service.execution.job_kinds.policy_input import resolve_policy_input
from service.execution.job_kinds.probe import prepare_probe, run_probe
from service.execution.job_kinds.train import prepare_train, run_train
from service.schemas.specs import AlignSpec, EvalSpec, ExportSpec, ProbeSpec, TrainSpec

JOB_KINDS: dict[str, JobKind] = {
    "train": JobKind("train", TrainSpec, run_train, "checkpoints/latest.pt", prepare_train, after_nothing),
    "align": JobKind("align", AlignSpec, run_align, None, prepare_align, register_aligned),
    "eval": JobKind("eval", EvalSpec, run_eval, None, resolve_policy_input, after_nothing),
    "export": JobKind("export", ExportSpec, run_export, None, resolve_policy_input, attach_onnx),
    "probe": JobKind(
        "probe",
        ProbeSpec,
        run_probe,
        "checkpoints/latest.json",
        prepare_probe,
        after_nothing,
        quick_prepare=True,
    ),
}


def job_kind(name: str) -> JobKind:
    try:
        return JOB_KINDS[name]
    except KeyError:
        raise ValueError(f"unknown job kind {name!r} (choose from {', '.join(JOB_KINDS)})") from None


def can_resume(kind: JobKind, run_dir: Path) -> bool:
    """An interrupted job resumes when its kind's resume checkpoint was written (a train job that
    only wrote `best.pt` or `metrics.csv` starts over: the trainer resumes from `latest.pt` only)."""
    return kind.resume_file is not None and (run_dir / kind.resume_file).is_file()
