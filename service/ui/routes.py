"""The dashboard's pages under `/ui` (server-rendered with Jinja2; `/` redirects to `/ui`).

Pages only read. Every action a page offers (cancel a job, move an alias, set a tag) is a `fetch` from
the browser to the REST API with the bearer token the person typed into the page, so an action is
allowed or refused by exactly the same code as a REST client's request. Templates autoescape every
value; data handed to the browser's scripts travels in `<script type="application/json">` blocks
written with Jinja's `tojson` (which escapes `<`, `>`, `&` and `'`), and a Content-Security-Policy
allows only the package's own scripts and styles.

Each page answers with a `Server-Timing: render;dur=<ms>` header (queries + template), which the
dashboard benchmark reads.
"""

from __future__ import annotations

import time
from datetime import UTC, datetime
from typing import Annotated, Any

from fastapi import APIRouter, Path, Query, Request
from fastapi.responses import HTMLResponse, RedirectResponse
from starlette.routing import NoMatchFound

from registry.errors import RegistryError
from service.database import job_store
from service.database.models import JOB_STATUSES
from service.deps import StateDep
from service.errors import JobNotFound
from service.schemas.config_overrides import algo_names
from service.schemas.jobs import JobKindName
from service.schemas.json_schema import MAX_SAFE_INTEGER
from service.ui.rendering import environment, render
from service.ui.views import SuccessTracker, diagnostic_groups, flatten_config, job_row, summary_success

PAGE_SIZE = 50
JOB_KINDS: tuple[str, ...] = JobKindName.__args__  # type: ignore[attr-defined]
LIVE_STATUSES = ("queued", "running")

router = APIRouter(prefix="/ui", include_in_schema=False)
root_router = APIRouter(include_in_schema=False)
_success = SuccessTracker()


@root_router.get("/")
async def root() -> RedirectResponse:
    return RedirectResponse("/ui", status_code=307)


def _page(template: str, started: float, status_code: int = 200, **context: Any) -> HTMLResponse:
    body = render(template, **context)
    elapsed = 1000 * (time.perf_counter() - started)
    return HTMLResponse(body, status_code=status_code, headers={"Server-Timing": f"render;dur={elapsed:.2f}"})


def _not_found(started: float, message: str) -> HTMLResponse:
    return _page("not_found.html", started, status_code=404, title="Not found", message=message)


def _jobs_context(
    state: Any, status: str | None, kind: str | None, page: int, experiment_id: int | None = None
) -> dict[str, Any]:
    offset = (page - 1) * PAGE_SIZE
    rows, count = job_store.list_jobs(
        state.database,
        status=status,
        kind=kind,
        offset=offset,
        limit=PAGE_SIZE,
        experiment_id=experiment_id,
    )
    successes = _success.current(state.database, rows)
    now = datetime.now(UTC)
    pages = max(1, -(-count // PAGE_SIZE))
    return {
        "jobs": [job_row(job, successes.get(job.id), now) for job in rows],
        "count": count,
        "page": page,
        "pages": pages,
        "first": offset + 1 if rows else 0,
        "last": offset + len(rows),
        "status": status or "",
        "kind": kind or "",
        "experiment_id": experiment_id or "",
        "statuses": JOB_STATUSES,
        "kinds": JOB_KINDS,
        "live": any(job.status in LIVE_STATUSES for job in rows) or page == 1,
    }


PageQuery = Annotated[int, Query(ge=1, le=10**7)]
ExperimentQuery = Annotated[int | None, Query(ge=1, le=MAX_SAFE_INTEGER)]


def _blank(value: str | None) -> str | None:
    return value or None


@router.get("", response_class=HTMLResponse)
def jobs_page(
    state: StateDep,
    status: Annotated[str | None, Query()] = None,
    kind: Annotated[str | None, Query()] = None,
    page: PageQuery = 1,
    experiment_id: ExperimentQuery = None,
) -> HTMLResponse:
    """The jobs table, newest first, filtered (status, kind, experiment) and paged; the page's script
    refreshes its rows."""
    started = time.perf_counter()
    status, kind = _blank(status), _blank(kind)
    if status is not None and status not in JOB_STATUSES:
        return _not_found(started, f"unknown status {status!r}")
    if kind is not None and kind not in JOB_KINDS:
        return _not_found(started, f"unknown kind {kind!r}")
    context = _jobs_context(state, status, kind, page, experiment_id)
    return _page("jobs.html", started, title="Jobs", nav="jobs", train_choices=_train_choices(), **context)


def _train_choices() -> dict[str, list[str]]:
    """The submit form's choices: the methods and profiles a train spec accepts."""
    from core.config import PROFILES
    from core.runs.profile_choice import AUTO_PROFILE

    return {"algos": list(algo_names()), "profiles": [AUTO_PROFILE, *sorted(PROFILES)]}


@router.get("/jobs/rows", response_class=HTMLResponse)
def jobs_rows(
    state: StateDep,
    status: Annotated[str | None, Query()] = None,
    kind: Annotated[str | None, Query()] = None,
    page: PageQuery = 1,
    experiment_id: ExperimentQuery = None,
) -> HTMLResponse:
    """The table's body and counts alone: what the jobs page polls (at most once a second)."""
    started = time.perf_counter()
    status, kind = _blank(status), _blank(kind)
    if (status is not None and status not in JOB_STATUSES) or (kind is not None and kind not in JOB_KINDS):
        return HTMLResponse("", status_code=404)
    context = _jobs_context(state, status, kind, page, experiment_id)
    return _page("_jobs_rows.html", started, **context)


@router.get("/jobs/{job_id}", response_class=HTMLResponse)
def job_page(job_id: Annotated[int, Path(ge=1, le=MAX_SAFE_INTEGER)], state: StateDep) -> HTMLResponse:
    """One job: spec and config, live learning curve and diagnostics, artifacts, cancel."""
    started = time.perf_counter()
    try:
        job = job_store.get_job(state.database, job_id=job_id)
        artifacts = job_store.list_artifacts(state.database, job_id=job_id)
    except JobNotFound:
        return _not_found(started, f"no job with id {job_id}")
    success = summary_success(job.summary) if job.summary else None
    if success is None:
        success = _success.current(state.database, [job]).get(job.id)
    row = job_row(job, success, datetime.now(UTC))
    config = (job.resolved or {}).get("config")
    resolved_rest = {k: v for k, v in (job.resolved or {}).items() if k != "config"}
    produced = state.registry.versions_from_job(job_id)
    return _page(
        "job.html",
        started,
        title=f"Job {job_id}",
        nav="jobs",
        job=job,
        row=row,
        config_sections=flatten_config(config) if isinstance(config, dict) else [],
        resolved_rest=resolved_rest,
        artifacts=artifacts,
        produced=produced,
        live=job.status in LIVE_STATUSES,
        page_data={
            "job_id": job.id,
            "status": job.status,
            "live": job.status in LIVE_STATUSES,
            "total": job.progress_total,
            "diagnostics": diagnostic_groups(),
        },
    )


MAX_COMPARED = 20
"""Jobs one compare page overlays (each curve is a request for the job's thinned series)."""


@router.get("/compare", response_class=HTMLResponse)
def compare_page(
    state: StateDep,
    jobs: Annotated[str, Query(max_length=400, description="Comma-separated job ids.")] = "",
) -> HTMLResponse:
    """Several jobs' learning curves overlaid on env steps, with a smoothing control (the page's script
    reads each job's thinned series)."""
    started = time.perf_counter()
    ids: list[int] = []
    for part in jobs.split(","):
        part = part.strip()
        if not part:
            continue
        if not part.isdigit() or not 1 <= int(part) <= MAX_SAFE_INTEGER:
            return _not_found(started, f"not a job id: {part!r}")
        if int(part) not in ids:
            ids.append(int(part))
    if len(ids) > MAX_COMPARED:
        return _not_found(started, f"at most {MAX_COMPARED} jobs can be compared at once")
    rows = job_store.get_jobs(state.database, job_ids=ids)
    found = {job.id: job for job in rows}
    now = datetime.now(UTC)
    compared = []
    for job_id in ids:
        job = found.get(job_id)
        if job is None:
            compared.append({"id": job_id, "label": f"job {job_id} (not found)", "missing": True})
            continue
        row = job_row(job, None, now)
        parts = [f"job {job_id}", row["method"] or job.kind]
        if job.cell:
            parts.append(job.cell)
        else:
            seed = f"seed {row['seed']}" if row["seed"] is not None else None
            parts += [p for p in (row["reward"], seed) if p]
        compared.append({"id": job_id, "label": " · ".join(parts), "status": job.status, "missing": False})
    return _page(
        "compare.html",
        started,
        title="Compare runs",
        nav="jobs",
        compared=compared,
        page_data={"jobs": [c for c in compared if not c["missing"]]},
    )


@router.get("/policies", response_class=HTMLResponse)
def policies_page(state: StateDep) -> HTMLResponse:
    """Every policy with its newest version and aliases."""
    started = time.perf_counter()
    policies = state.registry.list_policies()
    return _page(
        "policies.html",
        started,
        title="Registry",
        nav="policies",
        policies=policies,
        overview=state.registry.policy_overviews(),
    )


@router.get("/policies/{name}", response_class=HTMLResponse)
def policy_page(name: str, state: StateDep) -> HTMLResponse:
    """A policy's versions (newest first) with tags, aliases, lineage, source jobs and artifacts."""
    started = time.perf_counter()
    try:
        policy = state.registry.get_policy(name)
    except RegistryError as error:
        return _not_found(started, str(error))
    versions = list(reversed(policy.versions))
    lineages: dict[int, list[str]] = {}
    for version in versions:
        if version.parent:
            try:
                chain = state.registry.lineage(version.ref)
            except RegistryError:
                chain = []
            lineages[version.version] = [record.ref for record in chain[1:]]
    job_ids = {v.source_job_id for v in versions if v.source_job_id is not None}
    existing = job_store.existing_job_ids(state.database, job_ids=job_ids)
    return _page(
        "policy.html",
        started,
        title=f"Policy {policy.name}",
        nav="policies",
        policy=policy,
        versions=versions,
        lineages=lineages,
        existing_jobs=existing,
        page_data={"policy": policy.name},
    )


@router.get("/experiments", response_class=HTMLResponse)
def experiments_page(request: Request) -> HTMLResponse:
    """Experiments, newest first (the page's script reads `GET /experiments`)."""
    started = time.perf_counter()
    if not experiments_api(request.app):
        return _not_found(started, "this service has no experiments API")
    return _page("experiments.html", started, title="Experiments", nav="experiments")


@router.get("/experiments/{experiment_id}", response_class=HTMLResponse)
def experiment_page(
    experiment_id: Annotated[int, Path(ge=1, le=MAX_SAFE_INTEGER)], request: Request
) -> HTMLResponse:
    """One experiment: its grid of cells and their states, the report's table and figure; cancel."""
    started = time.perf_counter()
    if not experiments_api(request.app):
        return _not_found(started, "this service has no experiments API")
    return _page(
        "experiment.html",
        started,
        title=f"Experiment {experiment_id}",
        nav="experiments",
        page_data={"experiment_id": experiment_id},
    )


def experiments_api(app: Any) -> bool:
    """Whether the app serves the experiments endpoints (`GET /experiments`, route `list_experiments`)."""
    try:
        return app.url_path_for("list_experiments") == "/experiments"
    except NoMatchFound:
        return False


def install_dashboard(app: Any) -> None:
    """Mount the dashboard's pages, its static files and the `/` redirect on the FastAPI app."""
    from service.ui.rendering import static_files

    app.include_router(router)
    app.include_router(root_router)
    environment().globals["experiments_enabled"] = lambda: experiments_api(app)
    app.mount("/ui/static", static_files(), name="ui-static")
    app.add_middleware(_SecurityHeaders)


class _SecurityHeaders:
    """Content-Security-Policy and friends on every `/ui` response (pure ASGI: no body buffering)."""

    HEADERS = (
        (
            b"content-security-policy",
            b"default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
            b"connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; "
            b"frame-ancestors 'none'",
        ),
        (b"x-content-type-options", b"nosniff"),
        (b"referrer-policy", b"same-origin"),
        (b"x-frame-options", b"DENY"),
    )

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or not str(scope.get("path", "")).startswith("/ui"):
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: dict) -> None:
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message.get("headers", []), *self.HEADERS]}
            await send(message)

        await self.app(scope, receive, send_with_headers)
