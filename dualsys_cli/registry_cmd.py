"""`dualsys registry list|show|register|alias`: the policy registry, straight on its database.

Works with or without a running service (SQLite in WAL mode lets both use the database at once):
`--db`/`--artifacts` (or `DUALSYS_DATABASE_URL`/`DUALSYS_ARTIFACTS`) say where it lives, the same
defaults as `dualsys serve`. `register` takes a run directory trained anywhere, or `--job ID` of a
succeeded service job.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path
from typing import Any

import typer

from dualsys_cli.errors import user_errors

app = typer.Typer(help="Named, versioned policies: list, show, register, alias.", no_args_is_help=True)
DB = typer.Option(None, "--db", help="SQLite database file (default ./dualsys.db or DUALSYS_DATABASE_URL).")
ARTIFACTS = typer.Option(None, "--artifacts", help="Artifact root (default ./dualsys-artifacts).")
JSON = typer.Option(False, "--json", help="Print JSON.")


def _registry(db: Path | None, artifacts: Path | None, *, create: bool = False):  # type: ignore[no-untyped-def]
    """The registry of --db/--artifacts or the settings; only `register` may create a new database."""
    from sqlalchemy.engine import make_url

    from registry import PolicyRegistry, RegistrySettings
    from registry.settings import sqlite_url

    given: dict[str, Any] = {"database_url": sqlite_url(db) if db else None, "artifacts": artifacts}
    settings = RegistrySettings(**{k: v for k, v in given.items() if v is not None})
    url = make_url(settings.database_url)
    if not create and url.get_backend_name() == "sqlite" and url.database and not Path(url.database).exists():
        raise FileNotFoundError(
            f"no policy registry at {url.database} (register a policy first, or pass --db)"
        )
    return PolicyRegistry.from_settings(settings)


def _plain(record: Any) -> dict[str, Any]:
    return json.loads(json.dumps(asdict(record), default=str))


def _print_version(version: Any) -> None:
    typer.echo(f"{version.ref}  created {version.created_at:%Y-%m-%d %H:%M:%S}")
    typer.echo(f"  aliases: {', '.join(version.aliases) or '-'}   parent: {version.parent or '-'}")
    typer.echo(f"  source job: {version.source_job_id or '-'}   run dir: {version.source_run_dir}")
    typer.echo(f"  tags: {json.dumps(version.tags)}")
    typer.echo(f"  metrics: {json.dumps(version.metrics, default=str)}")
    for artifact in version.artifacts:
        typer.echo(f"  {artifact.kind:10} {artifact.size:>10}  {artifact.name}")


@app.command("list")
def list_policies(db: Path = DB, artifacts: Path = ARTIFACTS, as_json: bool = JSON) -> None:
    """Every registered policy with its newest version and aliases."""
    with user_errors():
        policies = _registry(db, artifacts).list_policies()
    if as_json:
        typer.echo(json.dumps([_plain(p) for p in policies]))
        return
    if not policies:
        typer.echo("no registered policies")
    for policy in policies:
        aliases = ", ".join(f"{a}→{v}" for a, v in policy.aliases.items()) or "-"
        typer.echo(f"{policy.name}  latest v{policy.latest_version}  aliases: {aliases}")


@app.command("show")
def show(
    ref: str = typer.Argument(..., help="NAME (all versions), NAME@VERSION or NAME@ALIAS."),
    db: Path = DB,
    artifacts: Path = ARTIFACTS,
    as_json: bool = JSON,
) -> None:
    """Show a policy's versions, or one version."""
    with user_errors():
        registry = _registry(db, artifacts)
        versions = [registry.resolve(ref)] if "@" in ref else registry.get_policy(ref).versions
    if as_json:
        typer.echo(json.dumps([_plain(v) for v in versions] if "@" not in ref else _plain(versions[0])))
        return
    for version in versions:
        _print_version(version)


@app.command("register")
def register(
    name: str = typer.Argument(..., help="Policy name (created on first registration)."),
    run_dir: Path = typer.Argument(None, help="Run directory holding checkpoints/*.pt."),
    job: int = typer.Option(None, "--job", min=1, help="A succeeded service job instead of RUN_DIR."),
    parent: str = typer.Option(None, "--parent", help="The version this one derives from (NAME@VERSION)."),
    tags: list[str] = typer.Option(None, "--tag", help="key=value (repeatable)."),
    description: str = typer.Option("", "--description"),
    db: Path = DB,
    artifacts: Path = ARTIFACTS,
    as_json: bool = JSON,
) -> None:
    """Register a run directory (or a finished job's) as the next version of NAME."""
    with user_errors():
        if (run_dir is None) == (job is None):
            raise ValueError("give either RUN_DIR or --job ID")
        tag_items = {}
        for item in tags or []:
            key, sep, value = item.partition("=")
            if not sep:
                raise ValueError(f"--tag {item!r} is not of the form key=value")
            tag_items[key.strip()] = value.strip()
        registry = _registry(db, artifacts, create=True)
        source_job = None
        if job is not None:
            run_dir, source_job = _job_run_dir(registry, job), job
        version = registry.register_run(
            name, run_dir, source_job_id=source_job, parent=parent, tags=tag_items, description=description
        )
    if as_json:
        typer.echo(json.dumps(_plain(version)))
    else:
        typer.echo(f"registered {version.ref}")


def _job_run_dir(registry: Any, job_id: int) -> Path:
    from service.database.migrate import upgrade_service
    from service.database.models import Job

    upgrade_service(registry.database.engine)
    with registry.database.read() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise ValueError(f"no job with id {job_id} in {registry.database.url}")
        if job.status != "succeeded":
            raise ValueError(f"job {job_id} is {job.status}; only a succeeded job can be registered")
        return registry.store.confine(job.run_dir)


@app.command("alias")
def alias(
    name: str = typer.Argument(..., help="Policy name."),
    alias_name: str = typer.Argument(..., metavar="ALIAS", help="Alias, e.g. champion."),
    version: int = typer.Argument(None, min=1, help="Version the alias points at."),
    delete: bool = typer.Option(False, "--delete", help="Remove the alias instead."),
    db: Path = DB,
    artifacts: Path = ARTIFACTS,
) -> None:
    """Point NAME@ALIAS at VERSION (or remove it with --delete)."""
    with user_errors():
        registry = _registry(db, artifacts)
        if delete:
            registry.delete_alias(name, alias_name)
            typer.echo(f"removed {name}@{alias_name}")
            return
        if version is None:
            raise ValueError("give the VERSION the alias should point at (or --delete)")
        record = registry.set_alias(name, alias_name, version)
    typer.echo(f"{name}@{alias_name} → {record.ref}")
