"""Running the service under uvicorn (what `dualsys serve` calls).

One API process (the default) serves HTTP and runs the supervisor in the same process.
`api_processes=N>1`: the parent process migrates the database and runs the one supervisor (claiming,
starting and following jobs, writing their records), binds the port, and uvicorn's process manager
starts N API processes on that socket, each an API-only replica (`run_jobs=False`) that queues jobs
for the supervisor, which finds them within `poll_interval_s`. The kernel spreads connections over
the processes. A dead API process is replaced; SIGTERM/SIGINT stops the API processes, then the
supervisor stops its workers and re-queues their jobs, as with one process.
"""

from __future__ import annotations

import ctypes
import functools
import logging
import signal
import sys

import uvicorn
from fastapi import FastAPI
from uvicorn.supervisors import Multiprocess

from registry.database import Database
from service.api.app import create_api
from service.database.migrate import upgrade_service
from service.settings import ServiceSettings
from service.ui.routes import install_dashboard

log = logging.getLogger("dualsys.service")
PR_SET_PDEATHSIG = 1
API_PROCESS_HEALTHCHECK_S = 120
"""How long uvicorn's process manager waits for an API process to answer its ping before killing and
replacing it. Its default (5 s) is shorter than importing the app takes on a loaded 2-core machine,
where it killed every starting process for minutes."""


def create_app(settings: ServiceSettings | None = None) -> FastAPI:
    """An API process's app: the REST API (`service.api`) with the web dashboard under `/ui` (`service.ui`)
    beside it. Composed here, above both, so that neither the API nor the dashboard imports the other."""
    app = create_api(settings)
    install_dashboard(app)
    return app


def serve(settings: ServiceSettings) -> None:
    """Check the bind address, then run uvicorn until SIGINT/SIGTERM (jobs re-queue on shutdown)."""
    settings.check_bind()
    if settings.api_processes > 1:
        serve_replicas(settings)
        return
    uvicorn.run(create_app(settings), **_uvicorn_options(settings))


def _uvicorn_options(settings: ServiceSettings) -> dict:
    return {
        "host": settings.host,
        "port": settings.port,
        "log_level": "info",
        "access_log": settings.access_log,
        "timeout_graceful_shutdown": int(settings.cancel_grace_s) + 5,
        "limit_concurrency": 1000,
    }


def api_replica(settings: ServiceSettings) -> FastAPI:
    """The app of one API process started by `serve_replicas` (a fresh interpreter: spawn)."""
    if sys.platform.startswith("linux"):  # end with the parent, even when it is killed (SIGKILL)
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    return create_app(settings)


def serve_replicas(settings: ServiceSettings) -> None:
    """N API processes on one socket, and the one supervisor in this (parent) process."""
    from service.execution.supervisor import Supervisor

    database = Database(settings.database_url)
    upgrade_service(database.engine)  # once, before any API process starts
    replica = settings.model_copy(update={"run_jobs": False, "api_processes": 1})
    config = uvicorn.Config(
        functools.partial(api_replica, replica),
        factory=True,
        workers=settings.api_processes,
        timeout_worker_healthcheck=API_PROCESS_HEALTHCHECK_S,
        **_uvicorn_options(settings),
    )
    config.configure_logging()
    supervisor = Supervisor(settings, database) if settings.run_jobs else None
    socket = config.bind_socket()
    try:
        if supervisor is not None:
            supervisor.start()
        log.info("supervisor %s; %d API processes", supervisor and supervisor.owner, settings.api_processes)
        Multiprocess(config, sockets=[socket]).run()
    finally:
        socket.close()
        if supervisor is not None:
            supervisor.stop()
        database.dispose()


def main() -> None:  # `python -m service.server`: settings from DUALSYS_* env vars only
    serve(ServiceSettings())


if __name__ == "__main__":
    main()
