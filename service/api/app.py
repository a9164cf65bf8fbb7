"""The REST API's FastAPI application: `create_api(settings)` (`service.server.create_app` adds the
dashboard of `service.ui` beside it; the API never imports the dashboard).

Start-up (lifespan): open the database, run `alembic upgrade head` (registry + service tables),
open the registry, start the supervisor (unless `DUALSYS_RUN_JOBS=false`, for an API-only
replica). Shutdown: the supervisor stops its workers and re-queues their jobs to resume.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio.to_thread
from fastapi import FastAPI
from starlette.concurrency import run_in_threadpool

from registry import PolicyRegistry
from registry.artifact_store import ArtifactStore
from registry.database import Database
from service.api.errors import install_error_handlers
from service.api.routes import experiments, health, jobs, policies
from service.api.size_limit import BodySizeLimit
from service.database.job_inserter import JobInserter
from service.database.migrate import upgrade_service
from service.deps import ServiceState
from service.execution.supervisor import Supervisor
from service.schemas.specs import warm_up_validators
from service.settings import ServiceSettings

log = logging.getLogger("dualsys.service")


def create_api(settings: ServiceSettings | None = None) -> FastAPI:
    settings = settings or ServiceSettings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        # few threads: request handlers are short and CPU-bound under the GIL, so a small pool queues
        # requests fairly (FIFO) instead of letting dozens of threads fight for the interpreter
        anyio.to_thread.current_default_thread_limiter().total_tokens = settings.request_threads
        database = Database(settings.database_url)
        await run_in_threadpool(upgrade_service, database.engine)
        # import the method registry (torch) once in the background, not on the first train request
        threading.Thread(target=warm_up_validators, name="dualsys-warm-up", daemon=True).start()
        registry = PolicyRegistry(database, ArtifactStore(settings.artifacts))
        supervisor = Supervisor(settings, database) if settings.run_jobs else None
        if supervisor is not None:
            await run_in_threadpool(supervisor.start)
        inserter = JobInserter(database)
        app.state.service = ServiceState(
            settings=settings, database=database, registry=registry, supervisor=supervisor, inserter=inserter
        )
        try:
            yield
        finally:
            inserter.stop()
            if supervisor is not None:
                await run_in_threadpool(supervisor.stop)
            database.dispose()

    app = FastAPI(
        title="dualsys job service",
        summary="Queue training, alignment, evaluation and export jobs; a registry of versioned policies.",
        version="0.1.0",
        lifespan=lifespan,
        # operation ids are the route functions' names (`get_job`), which the OpenAPI links name
        generate_unique_id_function=lambda route: route.name,
    )
    app.add_middleware(BodySizeLimit, max_bytes=settings.max_request_bytes)
    install_error_handlers(app)
    app.include_router(jobs.router)
    app.include_router(policies.router)
    app.include_router(experiments.router)
    app.include_router(health.router)
    return app
