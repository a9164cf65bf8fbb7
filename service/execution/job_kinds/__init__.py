"""Job kinds: what a worker runs for `train`, `align`, `eval`, `export` and `probe` jobs.

Each kind is a `JobKind`: its spec model, a `run(context) -> summary` function executed inside the
worker (process or Ray task; it never touches the database), whether an interrupted job can resume
from its checkpoint, a `prepare` step run at submission (resolving `name@alias` references), and an
`after_success` step run where the database is (registering an aligned policy, attaching an ONNX).
"""

from __future__ import annotations

from service.execution.job_kinds.base import JobContext, JobKind
from service.execution.job_kinds.catalogue import JOB_KINDS, job_kind

__all__ = ["JOB_KINDS", "JobContext", "JobKind", "job_kind"]
