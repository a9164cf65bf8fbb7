"""Running the service under uvicorn (what `dualsys serve` calls)."""

from __future__ import annotations

import uvicorn

from service.app import create_app
from service.settings import ServiceSettings


def serve(settings: ServiceSettings) -> None:
    """Check the bind address, then run uvicorn until SIGINT/SIGTERM (jobs re-queue on shutdown)."""
    settings.check_bind()
    uvicorn.run(
        create_app(settings),
        host=settings.host,
        port=settings.port,
        log_level="info",
        timeout_graceful_shutdown=int(settings.cancel_grace_s) + 5,
        limit_concurrency=1000,
    )


def main() -> None:  # `python -m service.server`: settings from DUALSYS_* env vars only
    serve(ServiceSettings())


if __name__ == "__main__":
    main()
