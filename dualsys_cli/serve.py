"""`dualsys serve`: the REST job service under uvicorn (see docs/service.md).

Options left out fall back to the `DUALSYS_*` environment variables, then to the defaults.
The bearer token comes only from `DUALSYS_TOKEN` (never a command-line argument, which other users
of the machine could read); without it the service binds only to loopback addresses.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from dualsys_cli.errors import user_errors


def serve_command(
    host: str = typer.Option(
        None, "--host", help="Bind address (default 127.0.0.1; others need DUALSYS_TOKEN)."
    ),
    port: int = typer.Option(None, "--port", min=0, max=65535, help="TCP port (default 8000)."),
    db: Path = typer.Option(None, "--db", help="SQLite database file (default ./dualsys.db)."),
    database_url: str = typer.Option(
        None, "--database-url", help="SQLAlchemy URL instead of --db (PostgreSQL)."
    ),
    artifacts: Path = typer.Option(None, "--artifacts", help="Artifact root (default ./dualsys-artifacts)."),
    workers: int = typer.Option(None, "--workers", min=1, max=64, help="Jobs run at once (default 1)."),
    executor: str = typer.Option(
        None, "--executor", help="local (a process per job) or ray (a Ray task per job)."
    ),
    ray_address: str = typer.Option(None, "--ray-address", help="Ray cluster address for --executor ray."),
    api_processes: int = typer.Option(
        None,
        "--api-processes",
        min=1,
        max=32,
        help="Processes serving the API on the port (default 1); one supervisor runs the jobs.",
    ),
) -> None:
    """Start the job service: REST API, SQLite queue, worker processes, policy registry."""
    import importlib.util

    from registry.settings import sqlite_url
    from service.server import serve
    from service.settings import ServiceSettings

    with user_errors():
        if db is not None and database_url is not None:
            raise ValueError("give either --db or --database-url, not both")
        if executor is not None and executor not in ("local", "ray"):
            raise ValueError(f"unknown executor {executor!r} (choose local or ray)")
        given: dict[str, Any] = {
            "host": host,
            "port": port,
            "database_url": sqlite_url(db) if db is not None else database_url,
            "artifacts": artifacts,
            "workers": workers,
            "executor": executor,
            "ray_address": ray_address,
            "api_processes": api_processes,
        }
        settings = ServiceSettings(**{k: v for k, v in given.items() if v is not None})
        settings.check_bind()
        if settings.database_url.startswith("postgresql") and importlib.util.find_spec("psycopg") is None:
            raise ValueError("a PostgreSQL database needs psycopg: pip install 'dualsys[postgres]'")
        if settings.executor == "ray" and importlib.util.find_spec("ray") is None:
            raise ValueError("--executor ray needs Ray: pip install 'dualsys[ray]'")
        serve(settings)
