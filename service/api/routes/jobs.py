"""`/jobs`: submit, list, show, cancel, delete, metrics, events, artifacts.

The hot endpoints are `async`. `GET /jobs` and `GET /jobs/{id}` read through `ServiceState.query`: on
the event loop for SQLite (a sub-millisecond indexed query that never waits: WAL readers take no lock),
sparing the hop to the thread pool and back and the GIL hand-offs between the loop and the pool's
threads; in the thread pool for PostgreSQL, whose round trips the threads overlap. `POST /jobs`
validates on the loop and awaits its row from the process's `JobInserter`, which writes the submissions
of each moment in one transaction (service/database/job_inserter.py), so the loop never waits for the write
lock.
Work that may take longer (a train spec's config resolution, downloads, metrics pages) stays in the
thread pool (docs/service.md, Performance).
"""

from __future__ import annotations

from functools import partial
from typing import Annotated

from fastapi import APIRouter, Header, HTTPException, Path, Query, Request, Response, status
from fastapi.responses import FileResponse, StreamingResponse
from starlette.concurrency import run_in_threadpool

from registry.artifact_store import ARTIFACT_NAME, ArtifactStore
from service.api.events import job_events, parse_last_event_id
from service.api.links import link, linked
from service.api.presenters import artifact_public, job_public, json_response, metric_public
from service.database import job_store
from service.deps import MutationAuth, StateDep
from service.execution.job_kinds import job_kind
from service.schemas.errors import ErrorPublic
from service.schemas.jobs import (
    ArtifactsPublic,
    JobCreate,
    JobKindName,
    JobPublic,
    JobsPublic,
    JobStatus,
    MetricSeriesPublic,
    MetricsPublic,
)
from service.schemas.json_schema import MAX_SAFE_INTEGER

router = APIRouter(prefix="/jobs", tags=["jobs"])
JobId = Annotated[int, Path(ge=1, le=MAX_SAFE_INTEGER, description="Job id.")]
ArtifactName = Annotated[
    str, Path(pattern=ARTIFACT_NAME.pattern, description="A file of the run directory, e.g. metrics.csv.")
]


def _job_links(expression: str) -> dict[str, dict]:
    """What can be done with the job whose id is at `expression`."""
    return {
        "GetJob": link("get_job", "The job.", job_id=expression),
        "CancelJob": link("cancel_job", "Cancel it.", job_id=expression),
        "DeleteJob": link("delete_job", "Delete it once finished.", job_id=expression),
        "JobMetrics": link("job_metrics", "Its episode records.", job_id=expression),
        "JobSeries": link("job_series", "Its records thinned for drawing.", job_id=expression),
        "JobArtifacts": link("job_artifacts", "Its files.", job_id=expression),
    }


CREATED_LINKS = _job_links("$response.body#/id")
ERRORS = {
    400: {"model": ErrorPublic, "description": "A body that cannot be read as JSON (not UTF-8)."},
    401: {"model": ErrorPublic},
    404: {"model": ErrorPublic},
    409: {"model": ErrorPublic},
    413: {"model": ErrorPublic},
    422: {"model": ErrorPublic},
}


@router.post(
    "",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=JobPublic,
    dependencies=[MutationAuth],
    responses={
        **ERRORS,
        **linked(202, "Queued; a worker process runs it.", **CREATED_LINKS),
        200: {"model": JobPublic, "description": "Replay of an Idempotency-Key", "links": CREATED_LINKS},
    },
)
async def submit_job(
    body: JobCreate,
    state: StateDep,
    idempotency_key: Annotated[str | None, Header(max_length=128)] = None,
) -> Response:
    """Queue a job; answers 202 with its id at once. A worker process does the work."""
    kind = job_kind(body.kind)
    if kind.quick_prepare:
        submission = kind.prepare(body.spec, state.registry)
    else:
        submission = await run_in_threadpool(kind.prepare, body.spec, state.registry)
    fields = {
        "kind": body.kind,
        "spec": body.spec.model_dump(mode="json"),
        "resolved": submission.resolved,
        "progress_total": submission.progress_total,
    }
    if idempotency_key is None:  # batched with the other submissions of this moment (group commit)
        job, created = await state.inserter.insert(**fields), True
    else:
        job, created = await run_in_threadpool(
            partial(job_store.create_job, state.database, idempotency_key=idempotency_key, **fields)
        )
    if state.supervisor is not None:
        state.supervisor.wake_to_claim()
    return json_response(
        job_public(job),
        status_code=status.HTTP_202_ACCEPTED if created else status.HTTP_200_OK,
        headers={"Location": f"/jobs/{job.id}"},
    )


@router.get(
    "",
    response_model=JobsPublic,
    responses={**ERRORS, **linked(200, "A page of jobs.", **_job_links("$response.body#/data/0/id"))},
)
async def list_jobs(
    state: StateDep,
    status_filter: Annotated[JobStatus | None, Query(alias="status")] = None,
    kind: JobKindName | None = None,
    offset: Annotated[int, Query(ge=0, le=10**9)] = 0,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    experiment_id: Annotated[
        int | None, Query(ge=1, le=MAX_SAFE_INTEGER, description="Only the cells of this experiment.")
    ] = None,
) -> Response:
    """Jobs, newest first, filtered by status, kind and experiment, paged with offset/limit."""
    rows, count = await state.query(
        job_store.list_jobs,
        state.database,
        status=status_filter,
        kind=kind,
        offset=offset,
        limit=limit,
        experiment_id=experiment_id,
    )
    return json_response(JobsPublic(data=[job_public(j) for j in rows], count=count))


@router.get("/{job_id}", response_model=JobPublic, responses=ERRORS)
async def get_job(job_id: JobId, state: StateDep) -> Response:
    return json_response(job_public(await state.query(job_store.get_job, state.database, job_id=job_id)))


@router.post(
    "/{job_id}/cancel",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=JobPublic,
    dependencies=[MutationAuth],
    responses=ERRORS,
)
def cancel_job(job_id: JobId, state: StateDep) -> JobPublic:
    """Cancel: a queued job at once; a running one's process is ended. 409 for a finished job."""
    job = job_store.request_cancel(state.database, job_id=job_id)
    if state.supervisor is not None:
        state.supervisor.wake()
    return job_public(job)


@router.delete(
    "/{job_id}", status_code=status.HTTP_204_NO_CONTENT, dependencies=[MutationAuth], responses=ERRORS
)
def delete_job(job_id: JobId, state: StateDep) -> Response:
    """Delete a finished job, its metrics and its run directory. 409 unless finished."""
    job = job_store.delete_job(state.database, job_id=job_id)
    store = state.registry.store
    ArtifactStore.remove_tree(store.confine(job.run_dir))
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get("/{job_id}/metrics", response_model=MetricsPublic, responses=ERRORS)
def job_metrics(
    job_id: JobId,
    state: StateDep,
    since: Annotated[int, Query(ge=0, le=10**9, description="Only episodes after this one.")] = 0,
    limit: Annotated[int, Query(ge=1, le=10_000)] = 1000,
) -> MetricsPublic:
    rows = job_store.list_metrics(state.database, job_id=job_id, since=since, limit=limit)
    return MetricsPublic(data=[metric_public(r) for r in rows], count=len(rows))


@router.get("/{job_id}/series", response_model=MetricSeriesPublic, responses=ERRORS)
def job_series(
    job_id: JobId,
    state: StateDep,
    points: Annotated[
        int, Query(ge=10, le=100_000, description="About how many records to return, besides evaluations.")
    ] = 1000,
) -> Response:
    """The job's episode records thinned for drawing: every k-th episode, the first and the last, and
    every greedy evaluation; all of them when there are at most `points`."""
    series = job_store.metric_series(state.database, job_id=job_id, points=points)
    return json_response(
        MetricSeriesPublic(
            data=[metric_public(r) for r in series.rows],
            count=len(series.rows),
            episodes=series.episodes,
            stride=series.stride,
        )
    )


@router.get(
    "/{job_id}/events",
    responses={**ERRORS, 200: {"content": {"text/event-stream": {}}, "description": "Server-sent events"}},
    response_class=StreamingResponse,
)
async def job_event_stream(
    job_id: JobId,
    request: Request,
    state: StateDep,
    since: Annotated[int, Query(ge=0, le=10**9)] = 0,
    last_event_id: Annotated[str | None, Header(max_length=32)] = None,
) -> StreamingResponse:
    """Live progress: `status`, `metric` (id = episode) and `end` events."""
    job_store.get_job(state.database, job_id=job_id)  # 404 before the stream starts
    resume_from = parse_last_event_id(last_event_id)
    start = max(since, resume_from) if resume_from is not None else since
    return StreamingResponse(
        job_events(request, state.database, job_id, start),
        media_type="text/event-stream",
        headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"},
    )


@router.get(
    "/{job_id}/artifacts",
    response_model=ArtifactsPublic,
    responses={
        **ERRORS,
        **linked(
            200,
            "The job's files.",
            DownloadArtifact=link(
                "download_job_artifact",
                "Download the first file.",
                job_id="$request.path.job_id",
                name="$response.body#/data/0/name",
            ),
        ),
    },
)
def job_artifacts(job_id: JobId, state: StateDep) -> ArtifactsPublic:
    """Files recorded for the job: checkpoints as they are written, every file once it ends."""
    rows = job_store.list_artifacts(state.database, job_id=job_id)
    return ArtifactsPublic(data=[artifact_public(job_id, r) for r in rows], count=len(rows))


@router.get(
    "/{job_id}/artifacts/{name:path}",
    response_class=FileResponse,
    responses={**ERRORS, 400: {"model": ErrorPublic}, 200: {"content": {"application/octet-stream": {}}}},
)
def download_job_artifact(job_id: JobId, name: ArtifactName, state: StateDep) -> FileResponse:
    """Download one file of the job's run directory; paths cannot leave it."""
    job = job_store.get_job(state.database, job_id=job_id)
    store = state.registry.store
    run_dir = store.confine(job.run_dir)
    path = store.confine(name, base=run_dir)
    if any(part.startswith(".") for part in path.relative_to(run_dir).parts) or not path.is_file():
        raise HTTPException(status_code=404, detail=f"job {job_id} has no artifact {name!r}")
    return FileResponse(path, filename=path.name, media_type="application/octet-stream")
