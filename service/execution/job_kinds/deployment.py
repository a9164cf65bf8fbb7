"""The `align`, `eval` and `export` kinds: thin calls into the deployment library functions
(`sim2real.align_encoder`, `core.deploy.evaluate_policy`, `core.deploy.export_onnx`).

Decisions: the policy is the checkpoint of the version resolved at submission; `align` writes the
aligned run directory to `<run_dir>/aligned` and registers it as the next version of `spec.name`
(default `<source>-aligned`) with the source version as parent; `export` attaches the ONNX file to
the source version; `eval` with `onnx` uses the version's exported ONNX when it has one. Options
left None are not passed, so the library's own defaults apply.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel

from registry.references import parse_policy_ref
from service.errors import SpecTargetNotFound
from service.execution.job_kinds.base import JobContext, Submission
from service.execution.job_kinds.policy_input import resolve_policy_input
from service.schemas.specs import AlignSpec, EvalSpec, ExportSpec

if TYPE_CHECKING:
    from registry import PolicyRegistry

ALIGNED_FOLDER = "aligned"
"""The aligned run directory inside an align job's run directory (registered as the new version)."""


def _given(**options: Any) -> dict[str, Any]:
    """The options a spec sets; those left None are not passed, so the library's defaults apply."""
    return {key: value for key, value in options.items() if value is not None}


def run_align(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, AlignSpec)
    from sim2real import align_encoder  # torch is imported by the worker, not by the API process

    report = align_encoder(
        **_given(
            policy_path=Path(context.resolved["checkpoint"]),
            pairs_dir=Path(spec.pairs_dir).expanduser(),
            out_dir=context.run_dir / ALIGNED_FOLDER,
            epochs=spec.epochs,
            batch_size=spec.batch_size,
        )
    )
    return report.to_dict()


def run_eval(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, EvalSpec)
    from core.deploy import evaluate_policy

    # an exported ONNX of the version is used as it is; otherwise the checkpoint (exported on the fly)
    source = (
        context.resolved["onnx"]
        if spec.onnx and context.resolved.get("onnx")
        else context.resolved["checkpoint"]
    )
    if source is None:
        raise ValueError(f"{context.resolved['policy']} has no checkpoint to evaluate")
    report = evaluate_policy(
        **_given(
            policy_path=Path(source),
            trials=spec.trials,
            max_steps=spec.max_steps,
            domain=spec.domain,
            seed=spec.seed,
            onnx=spec.onnx,
        )
    )
    summary = report.to_dict()
    summary.pop("per_trial", None)  # kept in the job's log; the summary stays small
    return summary


def run_export(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, ExportSpec)
    from core.deploy import export_onnx

    out = context.run_dir / spec.out
    report = export_onnx(policy_path=Path(context.resolved["checkpoint"]), out=out)
    if not out.is_file():
        raise RuntimeError(f"export finished without writing {spec.out}")
    return {"onnx": spec.out, **report.to_dict()}


def register_aligned(
    registry: PolicyRegistry,
    job_id: int,
    spec: BaseModel,
    resolved: dict[str, Any],
    run_dir: Path,
    summary: dict,
) -> dict[str, Any]:
    assert isinstance(spec, AlignSpec)
    source = resolved["policy"]
    name = spec.name or f"{parse_policy_ref(source).name}-aligned"
    record = registry.register_run(
        name, run_dir, source_job_id=job_id, parent=source, tags={"kind": "aligned"}
    )
    return {"registered": record.ref}


def attach_onnx(
    registry: PolicyRegistry,
    job_id: int,
    spec: BaseModel,
    resolved: dict[str, Any],
    run_dir: Path,
    summary: dict,
) -> dict[str, Any]:
    assert isinstance(spec, ExportSpec)
    record = registry.add_artifact(resolved["policy"], run_dir / spec.out)
    return {"attached_to": record.ref}


def prepare_align(spec: BaseModel, registry: PolicyRegistry) -> Submission:
    """The pairs folder must exist on the server; then resolve the source policy."""
    assert isinstance(spec, AlignSpec)
    try:
        found = Path(spec.pairs_dir).expanduser().is_dir()
    except (OSError, ValueError):  # a name too long for the file system, or not encodable
        found = False
    if not found:
        raise SpecTargetNotFound(
            f"spec.pairs_dir: {spec.pairs_dir} is not a directory on the server", field="spec.pairs_dir"
        )
    return resolve_policy_input(spec, registry)
