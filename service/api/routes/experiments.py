"""`/experiments`: queue an experiment file's cells as train jobs, follow them, read the report."""

from __future__ import annotations

import threading
from typing import Annotated, Any

from fastapi import APIRouter, Path, Query, Response, status

from service import experiment_store
from service.api.deps import MutationAuth, ServiceState, StateDep
from service.api.presenters import json_response
from service.schemas.errors import ErrorPublic
from service.schemas.experiments import (
    CellCounts,
    CellPublic,
    ExperimentCreate,
    ExperimentPublic,
    ExperimentsPublic,
    ExperimentSummary,
)

router = APIRouter(prefix="/experiments", tags=["experiments"])
ExperimentId = Annotated[int, Path(ge=1, le=2**63 - 1, description="Experiment id.")]
ERRORS = {
    401: {"model": ErrorPublic},
    404: {"model": ErrorPublic},
    413: {"model": ErrorPublic},
    422: {"model": ErrorPublic},
}

_reports: dict[tuple[int, tuple[int, ...]], dict[str, Any]] = {}
_reports_lock = threading.Lock()


def _report(state: ServiceState, current: experiment_store.ExperimentState) -> dict[str, Any] | None:
    """The library's report of the finished cells, computed once per set of finished cells (its
    bootstrap takes a while) and kept for the latest set of each experiment."""
    from core.experiments import build_report

    done = tuple(job.id for job in current.jobs if job.status == "succeeded")
    if not done:
        return None
    key = (current.experiment.id, done)
    with _reports_lock:
        if key in _reports:
            return _reports[key]
    report = build_report(state.registry.store.confine(current.experiment.directory))
    with _reports_lock:
        for old in [k for k in _reports if k[0] == current.experiment.id]:
            del _reports[old]
        _reports[key] = report
    return report


def _public(state: ServiceState, experiment_id: int, *, with_report: bool) -> ExperimentPublic:
    current = experiment_store.get_experiment(state.database, experiment_id=experiment_id)
    experiment, counts = current.experiment, current.counts
    return ExperimentPublic(
        id=experiment.id,
        name=experiment.name,
        status=current.status,  # type: ignore[arg-type]
        workers=experiment.workers,
        cancel_requested=experiment.cancel_requested,
        created_at=experiment.created_at,
        spec=experiment.spec,
        cells=CellCounts(
            total=len(current.jobs),
            done=counts.get("succeeded", 0),
            running=counts.get("running", 0),
            queued=counts.get("queued", 0),
            failed=counts.get("failed", 0),
            cancelled=counts.get("cancelled", 0),
        ),
        jobs=[
            CellPublic(
                job_id=job.id,
                cell=job.cell or "",
                status=job.status,
                attempt=job.attempt,
                episode=job.progress_episode,
                reason=job.reason,
            )
            for job in current.jobs
        ],
        report=_report(state, current) if with_report else None,
    )


@router.post(
    "",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=ExperimentPublic,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def submit_experiment(body: ExperimentCreate, state: StateDep) -> Response:
    """Validate an experiment file and queue its cells as train jobs (202); 422 names the bad key."""
    experiment_id = experiment_store.create_experiment(
        state.database, state.registry.store, content=body.content, workers=body.workers
    )
    if state.supervisor is not None:
        state.supervisor.wake()
    return json_response(
        _public(state, experiment_id, with_report=False),
        status_code=status.HTTP_202_ACCEPTED,
        headers={"Location": f"/experiments/{experiment_id}"},
    )


@router.get("", response_model=ExperimentsPublic, responses=ERRORS)
def list_experiments(
    state: StateDep,
    offset: Annotated[int, Query(ge=0, le=10**9)] = 0,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> Response:
    """Experiments, newest first."""
    rows, count = experiment_store.list_experiments(state.database, offset=offset, limit=limit)
    data = [
        ExperimentSummary(
            id=r.id,
            name=r.name,
            workers=r.workers,
            cancel_requested=r.cancel_requested,
            created_at=r.created_at,
        )
        for r in rows
    ]
    return json_response(ExperimentsPublic(data=data, count=count))


@router.get("/{experiment_id}", response_model=ExperimentPublic, responses=ERRORS)
def get_experiment(
    experiment_id: ExperimentId,
    state: StateDep,
    report: Annotated[bool, Query(description="Include the report's numbers (once a cell is done).")] = True,
) -> Response:
    """Cells done / running / queued / failed, each cell's job, and the report's numbers."""
    return json_response(_public(state, experiment_id, with_report=report))


@router.delete(
    "/{experiment_id}",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=ExperimentPublic,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def cancel_experiment(experiment_id: ExperimentId, state: StateDep) -> Response:
    """Cancel the unfinished cells (queued ones at once, running ones are stopped); finished cells stay."""
    experiment_store.cancel_experiment(state.database, experiment_id=experiment_id)
    if state.supervisor is not None:
        state.supervisor.wake()
    return json_response(
        _public(state, experiment_id, with_report=False), status_code=status.HTTP_202_ACCEPTED
    )
