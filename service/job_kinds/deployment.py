"""The `align`, `eval` and `export` kinds: thin calls into the deployment library functions.

Decisions: the policy is the checkpoint of the version resolved at submission; `align` registers
its output as the next version of `spec.name` (default `<source>-aligned`) with the source version
as parent; `export` attaches the ONNX file to the source version. Options left None are not passed,
so the library's own defaults apply.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel

from registry import PolicyRegistry, parse_policy_ref
from service.errors import SpecRejected
from service.job_kinds.base import JobContext, Submission
from service.job_kinds.library import as_summary, call_with_options, library_function
from service.job_kinds.policy_input import resolve_policy_input
from service.schemas.specs import AlignSpec, EvalSpec, ExportSpec

ALIGN_FUNCTIONS = [("sim2real.align", "align_policy")]
EVAL_FUNCTIONS = [("core.evaluation", "evaluate_policy"), ("core.deploy", "evaluate_policy")]
EXPORT_FUNCTIONS = [("core.deploy", "export_onnx"), ("core.export", "export_onnx")]


def run_align(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, AlignSpec)
    align_policy = library_function("align", ALIGN_FUNCTIONS)
    result = call_with_options(
        align_policy,
        Path(context.resolved["checkpoint"]),
        Path(spec.pairs_dir),
        out_dir=context.run_dir,
        epochs=spec.epochs,
        batch_size=spec.batch_size,
    )
    return as_summary(result)


def run_eval(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, EvalSpec)
    evaluate = library_function("eval", EVAL_FUNCTIONS)
    source = context.resolved["onnx"] if spec.onnx else context.resolved["checkpoint"]
    if source is None:
        raise ValueError(
            f"{context.resolved['policy']} has no {'ONNX' if spec.onnx else 'checkpoint'} artifact"
        )
    result = call_with_options(
        evaluate,
        Path(source),
        trials=spec.trials,
        max_steps=spec.max_steps,
        domain=spec.domain,
        seed=spec.seed,
    )
    return as_summary(result)


def run_export(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, ExportSpec)
    export = library_function("export", EXPORT_FUNCTIONS)
    out = context.run_dir / spec.out
    result = call_with_options(export, Path(context.resolved["checkpoint"]), out)
    if not out.is_file():
        raise RuntimeError(f"export finished without writing {spec.out}")
    return {"onnx": spec.out, **as_summary(result)}


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
    if not Path(spec.pairs_dir).expanduser().is_dir():
        raise SpecRejected(
            f"spec.pairs_dir: {spec.pairs_dir} is not a directory on the server", field="spec.pairs_dir"
        )
    return resolve_policy_input(spec, registry)
