"""`/experiments`: queue an experiment file's cells as train jobs, follow them, read the report."""

from __future__ import annotations

import logging
import threading
from typing import Annotated, Any

from fastapi import APIRouter, Path, Query, Response, status

from registry.artifact_store import ArtifactStore
from service.api.links import link, linked
from service.api.presenters import json_response
from service.database import experiment_store
from service.deps import MutationAuth, ServiceState, StateDep
from service.schemas.errors import ErrorPublic
from service.schemas.experiments import (
    CellCounts,
    CellPublic,
    ExperimentCreate,
    ExperimentPublic,
    ExperimentsPublic,
    ExperimentSummary,
)
from service.schemas.json_schema import MAX_SAFE_INTEGER

log = logging.getLogger("dualsys.service")
router = APIRouter(prefix="/experiments", tags=["experiments"])
ExperimentId = Annotated[int, Path(ge=1, le=MAX_SAFE_INTEGER, description="Experiment id.")]
ERRORS = {
    400: {"model": ErrorPublic, "description": "A body that cannot be read as JSON (not UTF-8)."},
    401: {"model": ErrorPublic},
    404: {"model": ErrorPublic},
    409: {"model": ErrorPublic},
    413: {"model": ErrorPublic},
    422: {"model": ErrorPublic},
}


def _experiment_links(expression: str) -> dict[str, dict]:
    return {
        "GetExperiment": link("get_experiment", "The experiment.", experiment_id=expression),
        "CancelExperiment": link(
            "cancel_experiment", "Cancel its unfinished cells.", experiment_id=expression
        ),
        "DeleteExperiment": link(
            "delete_experiment", "Delete it once every cell has finished.", experiment_id=expression
        ),
        "ExperimentJobs": link("list_jobs", "Its cells' jobs.", experiment_id=expression),
    }


_reports: dict[int, tuple[tuple[int, ...], dict[str, Any]]] = {}
"""Per experiment: the finished cells the latest report covers, and the report."""
_computing: set[tuple[int, tuple[int, ...]]] = set()
_reports_lock = threading.Lock()


def _report(state: ServiceState, current: experiment_store.ExperimentState) -> tuple[dict | None, bool]:
    """(report, pending): the library's report of the finished cells, and whether a newer one is being
    computed. Its bootstrap takes seconds of CPU, so it runs in a background thread once per set of
    finished cells, and a request gets the latest finished report at once (None before the first)."""
    done = tuple(job.id for job in current.jobs if job.status == "succeeded")
    if not done:
        return None, False
    experiment_id = current.experiment.id
    key = (experiment_id, done)
    with _reports_lock:
        covered, report = _reports.get(experiment_id, ((), None))
        if covered == done:
            return report, False
        if key not in _computing:
            _computing.add(key)
            folder = state.registry.store.confine(current.experiment.directory)
            threading.Thread(
                target=_compute_report, args=(key, folder), name="dualsys-report", daemon=True
            ).start()
    return report, True


def _compute_report(key: tuple[int, tuple[int, ...]], folder: Any) -> None:
    from core.experiments import build_report

    try:
        report = build_report(folder)
    except Exception:  # a report of a half-written folder: the next request tries again
        log.exception("report of experiment %s failed", key[0])
        report = None
    with _reports_lock:
        _computing.discard(key)
        if report is not None and len(key[1]) >= len(_reports.get(key[0], ((), None))[0]):
            _reports[key[0]] = (key[1], report)


def _public(state: ServiceState, experiment_id: int, *, with_report: bool) -> ExperimentPublic:
    current = experiment_store.get_experiment(state.database, experiment_id=experiment_id)
    experiment, counts = current.experiment, current.counts
    report, pending = _report(state, current) if with_report else (None, False)
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
        report=report,
        report_pending=pending,
    )


@router.post(
    "",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=ExperimentPublic,
    dependencies=[MutationAuth],
    responses={**ERRORS, **linked(202, "Its cells are queued.", **_experiment_links("$response.body#/id"))},
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


@router.get(
    "",
    response_model=ExperimentsPublic,
    responses={
        **ERRORS,
        **linked(200, "A page of experiments.", **_experiment_links("$response.body#/data/0/id")),
    },
)
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


@router.post(
    "/{experiment_id}/cancel",
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


@router.delete(
    "/{experiment_id}",
    status_code=status.HTTP_204_NO_CONTENT,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def delete_experiment(experiment_id: ExperimentId, state: StateDep) -> Response:
    """Delete a finished experiment: its row, its cells' jobs and metrics, and its folder. 409 while a
    cell is queued or running (cancel it first)."""
    directory = experiment_store.delete_experiment(state.database, experiment_id=experiment_id)
    ArtifactStore.remove_tree(state.registry.store.confine(directory))
    with _reports_lock:
        _reports.pop(experiment_id, None)
    return Response(status_code=status.HTTP_204_NO_CONTENT)
