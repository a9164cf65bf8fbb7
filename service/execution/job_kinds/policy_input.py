"""Submission-time resolution of a spec's `policy` reference to one registry version."""

from __future__ import annotations

from typing import TYPE_CHECKING

from pydantic import BaseModel

from registry.errors import PolicyNotFound, RegistryError, VersionNotFound
from service.errors import SpecRejected, SpecTargetConflict, SpecTargetNotFound
from service.execution.job_kinds.base import Submission

if TYPE_CHECKING:
    from registry import PolicyRegistry


def resolve_policy_input(spec: BaseModel, registry: PolicyRegistry) -> Submission:
    """`name@alias` → `name@version` plus its checkpoint/ONNX paths, fixed for the job's lifetime."""
    reference = spec.policy
    try:
        record = registry.resolve(reference)
    except (PolicyNotFound, VersionNotFound) as error:
        raise SpecTargetNotFound(f"spec.policy: {error}", field="spec.policy") from error
    except RegistryError as error:
        raise SpecRejected(f"spec.policy: {error}", field="spec.policy") from error
    if record.checkpoint is None and record.onnx is None:
        raise SpecTargetConflict(f"spec.policy: {record.ref} has no checkpoint", field="spec.policy")
    return Submission(
        resolved={
            "policy": record.ref,
            "checkpoint": str(record.checkpoint) if record.checkpoint else None,
            "onnx": str(record.onnx) if record.onnx else None,
        }
    )
