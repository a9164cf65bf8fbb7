"""`dualsys experiments submit|show|watch|report|cancel`: experiment files run as jobs on a service.

The service (`dualsys serve`) queues each cell of the file as a train job and runs `--workers` of them
at a time on its executor; `report ID --out DIR` downloads the finished cells' metrics and summaries
and writes the same report.md and figures as `dualsys experiment report` (core.experiments).
URL from `--url` or `DUALSYS_URL`, token from `DUALSYS_TOKEN`.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import typer

from dualsys_cli.errors import user_errors

app = typer.Typer(
    help="Experiment files (methods × rewards × seeds) run as jobs on a dualsys service.",
    no_args_is_help=True,
)
URL = typer.Option(None, "--url", envvar="DUALSYS_URL", help="Service URL (default http://127.0.0.1:8000).")
JSON = typer.Option(False, "--json", help="Print JSON.")
CELL_FILES = ("metrics.csv", "summary.json", "config.yaml")
"""What the report reads from each finished cell."""


def _client(url: str | None):  # type: ignore[no-untyped-def]
    from service.client import ServiceClient

    return ServiceClient(url)


def _line(experiment: dict[str, Any]) -> str:
    cells = experiment["cells"]
    return (
        f"experiment {experiment['id']} {experiment['name']}: {experiment['status']} · "
        f"{cells['done']}/{cells['total']} done · {cells['running']} running · {cells['queued']} queued · "
        f"{cells['failed']} failed" + (f" · {cells['cancelled']} cancelled" if cells["cancelled"] else "")
    )


@app.command("submit")
def submit(
    file: Path = typer.Argument(..., help="Experiment file (YAML, the format of `dualsys experiment run`)."),
    workers: int = typer.Option(1, "--workers", min=1, max=64, help="Cells of it run at once, at most."),
    url: str = URL,
    as_json: bool = JSON,
) -> None:
    """Queue every cell of FILE as a train job; prints the experiment's id."""
    with user_errors():
        if not file.is_file():
            raise ValueError(f"experiment file not found: {file}")
        with _client(url) as client:
            experiment = client.submit_experiment(file.read_text(), workers=workers)
    if as_json:
        typer.echo(json.dumps({"id": experiment["id"], "cells": experiment["cells"]["total"]}))
    else:
        typer.echo(
            f"experiment {experiment['id']} {experiment['name']}: "
            f"{experiment['cells']['total']} cells queued; "
            f"follow it with: dualsys experiments watch {experiment['id']}"
        )


@app.command("show")
def show(experiment_id: int = typer.Argument(..., min=1), url: str = URL, as_json: bool = JSON) -> None:
    """Cells done / running / queued / failed, each cell's job, and the report's numbers."""
    with user_errors(), _client(url) as client:
        experiment = client.experiment(experiment_id)
    if as_json:
        typer.echo(json.dumps(experiment))
        return
    typer.echo(_line(experiment))
    for job in experiment["jobs"]:
        reason = f"  ({job['reason']})" if job["reason"] and job["status"] != "succeeded" else ""
        typer.echo(
            f"  {job['cell']:<32} job {job['job_id']:<6} {job['status']:<10} ep {job['episode']}{reason}"
        )
    report = experiment.get("report")
    if report:
        for label, rewards in report["methods"].items():
            for reward, entry in rewards.items():
                auc, final = entry["auc"], entry["final_perf"]
                typer.echo(
                    f"  {label:<16} {reward:<7} AuC IQM {_number(auc['iqm'])} · "
                    f"Final Perf IQM {_number(final['iqm'])} · seeds {entry['seeds']}"
                )


def _number(value: Any) -> str:
    return "–" if value is None else f"{value:.3f}"


@app.command("watch")
def watch(
    experiment_id: int = typer.Argument(..., min=1),
    interval: float = typer.Option(2.0, "--interval", min=0.2, help="Seconds between polls."),
    url: str = URL,
) -> None:
    """Print the experiment's progress as it changes, until no cell is queued or running."""
    last = ""
    with user_errors(), _client(url) as client:
        while True:
            experiment = client.experiment(experiment_id, report=False)
            line = _line(experiment)
            if line != last:
                typer.echo(line)
                last = line
            if experiment["cells"]["running"] == 0 and experiment["cells"]["queued"] == 0:
                return
            time.sleep(interval)


@app.command("cancel")
def cancel(experiment_id: int = typer.Argument(..., min=1), url: str = URL) -> None:
    """Cancel the unfinished cells; finished ones stay."""
    with user_errors(), _client(url) as client:
        experiment = client.cancel_experiment(experiment_id)
    typer.echo(_line(experiment))


@app.command("report")
def report(
    experiment_id: int = typer.Argument(..., min=1),
    out: Path = typer.Option(..., "--out", help="Folder for <experiment>/report.md, the figures and cells."),
    url: str = URL,
) -> None:
    """Download the finished cells and write report.md and the figures (as `dualsys experiment report`)."""
    import yaml

    from core.experiments import write_report
    from core.experiments.cells import EXPERIMENT_FILE

    with user_errors(), _client(url) as client:
        experiment = client.experiment(experiment_id, report=False)
        done = [job for job in experiment["jobs"] if job["status"] == "succeeded"]
        if not done:
            raise ValueError(f"experiment {experiment_id} has no finished cell yet")
        root = out / experiment["name"]
        root.mkdir(parents=True, exist_ok=True)
        (root / EXPERIMENT_FILE).write_text(
            yaml.safe_dump(experiment["spec"], sort_keys=False, allow_unicode=True)
        )
        for job in done:
            cell_dir = root / job["cell"]
            cell_dir.mkdir(parents=True, exist_ok=True)
            for name in CELL_FILES:
                (cell_dir / name).write_bytes(client.artifact(job["job_id"], name))
        result = write_report(root)
    typer.echo(f"{len(done)}/{experiment['cells']['total']} cells; report: {result['files']['report']}")
    for name in ("learning_curves", "success_curves", "scores"):
        typer.echo(f"  {name}: {result['files'][name]}")
