"""`dualsys jobs submit|list|show|cancel|watch`: the job service's HTTP client (httpx).

The service URL comes from `--url` or `DUALSYS_URL` (default http://127.0.0.1:8000), the bearer
token from `DUALSYS_TOKEN`. `submit <kind>` takes the same options as the matching command: `submit
train` every option of `dualsys train` (--algo --env --reward --seed --episodes --steps --minutes --profile
--set --config --ac --tensorboard/--no-tensorboard --json) but `TRAIN_ONLY`
(tests/service/test_jobs_submit_options.py compares the two commands).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from dualsys_cli.errors import user_errors

app = typer.Typer(help="Submit and follow jobs on a dualsys service (dualsys serve).", no_args_is_help=True)
submit_app = typer.Typer(help="Queue a job; prints its id.", no_args_is_help=True)
app.add_typer(submit_app, name="submit")

URL = typer.Option(None, "--url", envvar="DUALSYS_URL", help="Service URL (default http://127.0.0.1:8000).")
TRAIN_ONLY = ("--out", "--resume")
"""`dualsys train`'s options that `jobs submit train` does not take: both name a run directory on this
machine, where the service chooses and keeps each job's own (resume a job by re-queueing it, not by path)."""
JSON = typer.Option(False, "--json", help="Print JSON.")


def _client(url: str | None):  # type: ignore[no-untyped-def]
    from service.client import ServiceClient

    return ServiceClient(url)


def _submit(url: str | None, kind: str, spec: dict[str, Any], as_json: bool) -> None:
    with user_errors(), _client(url) as client:
        job = client.submit(kind, {k: v for k, v in spec.items() if v is not None})
    if as_json:
        typer.echo(json.dumps({"id": job["id"], "status": job["status"]}))
    else:
        typer.echo(
            f"job {job['id']} {job['status']} ({kind}); follow it with: dualsys jobs watch {job['id']}"
        )


def _overrides(items: list[str] | None) -> dict[str, Any]:
    """`--set section.key=value` items as the typed values the API takes (`32`, `true`, `[8, 8]`)."""
    from service.schemas.config_overrides import typed_overrides

    overrides = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            with user_errors():
                raise ValueError(f"--set {item!r} is not of the form section.key=value")
        overrides[key.strip()] = value.strip()
    return typed_overrides(overrides)


@submit_app.command("train")
def submit_train(
    algo: str = typer.Option(None, "--algo", help="Method name (default: the profile's)."),
    env: str = typer.Option(
        None, "--env", help="Gymnasium id (default dualsys/NicoGrasp-v0; `dualsys env list` shows the ids)."
    ),
    reward: str = typer.Option(None, "--reward", help="NicoGrasp's reward: dense | sparse."),
    seed: int = typer.Option(None, "--seed"),
    episodes: int = typer.Option(None, "--episodes", min=1),
    steps: int = typer.Option(None, "--steps", min=1),
    minutes: float = typer.Option(None, "--minutes", min=0.0),
    profile: str = typer.Option(
        "auto", "--profile", help="default | paper | vector; auto: vector for vector observations."
    ),
    overrides: list[str] = typer.Option(None, "--set", help="section.key=value (repeatable)."),
    config_file: Path = typer.Option(
        None,
        "--config",
        help="YAML/JSON file of config sections (read here, sent as overrides before --set).",
    ),
    ac: str = typer.Option(None, "--ac", help="The learner: ddpg | cacla | td3 | sac."),
    tensorboard: bool = typer.Option(
        None,
        "--tensorboard/--no-tensorboard",
        help="Write TensorBoard event files into the job's run directory (run.tensorboard).",
    ),
    url: str = URL,
    as_json: bool = JSON,
) -> None:
    """Queue a training run: the options of `dualsys train`, in the same order (profile, --config, --set,
    then the named ones), except --out and --resume (the service keeps each job's run directory)."""
    items = _config_file_overrides(config_file)
    items.update(_overrides(overrides))
    if tensorboard is not None:
        items["run.tensorboard"] = tensorboard
    if env is not None:
        items["env.id"] = env
    spec = {
        "algo": algo,
        "reward": reward,
        "seed": seed,
        "episodes": episodes,
        "steps": steps,
        "minutes": minutes,
        "profile": profile,
        "overrides": items,
        "ac": ac,
    }
    _submit(url, "train", spec, as_json)


def _config_file_overrides(path: Path | None) -> dict[str, Any]:
    """A `--config` file's sections as typed `section.key` overrides (text read as `--set` reads it)."""
    if path is None:
        return {}
    from core.config import read_config_file

    with user_errors():
        data = read_config_file(path)
        flat: dict[str, Any] = {}
        for section, values in data.items():
            if not isinstance(values, dict):
                raise ValueError(f"--config {path}: section {section!r} must be a mapping")
            for key, value in values.items():
                flat[f"{section}.{key}"] = value
    from service.schemas.config_overrides import typed_overrides

    texts = typed_overrides({k: v for k, v in flat.items() if isinstance(v, str)})
    return {k: texts.get(k, list(v) if isinstance(v, tuple) else v) for k, v in flat.items()}


@submit_app.command("align")
def submit_align(
    policy: str = typer.Option(..., "--policy", help="name, name@VERSION or name@ALIAS."),
    pairs_dir: str = typer.Option(
        ..., "--pairs-dir", help="Folder of paired sim/real images (on the server)."
    ),
    epochs: int = typer.Option(None, "--epochs", min=1),
    batch_size: int = typer.Option(None, "--batch-size", min=1),
    name: str = typer.Option(None, "--name", help="Registered name of the aligned policy."),
    url: str = URL,
    as_json: bool = JSON,
) -> None:
    """Queue a sim-to-real alignment of a registered policy."""
    spec = {
        "policy": policy,
        "pairs_dir": pairs_dir,
        "epochs": epochs,
        "batch_size": batch_size,
        "name": name,
    }
    _submit(url, "align", spec, as_json)


@submit_app.command("eval")
def submit_eval(
    policy: str = typer.Option(..., "--policy", help="name, name@VERSION or name@ALIAS."),
    trials: int = typer.Option(None, "--trials", min=1),
    max_steps: int = typer.Option(None, "--max-steps", min=1),
    domain: str = typer.Option(None, "--domain", help="sim | real."),
    seed: int = typer.Option(None, "--seed"),
    onnx: bool = typer.Option(None, "--onnx/--no-onnx", help="Evaluate the exported ONNX."),
    url: str = URL,
    as_json: bool = JSON,
) -> None:
    """Queue a grasp-trial evaluation of a registered policy."""
    spec = {
        "policy": policy,
        "trials": trials,
        "max_steps": max_steps,
        "domain": domain,
        "seed": seed,
        "onnx": onnx,
    }
    _submit(url, "eval", spec, as_json)


@submit_app.command("export")
def submit_export(
    policy: str = typer.Option(..., "--policy", help="name, name@VERSION or name@ALIAS."),
    out: str = typer.Option(None, "--out", help="ONNX file name (default policy.onnx)."),
    url: str = URL,
    as_json: bool = JSON,
) -> None:
    """Queue an ONNX export of a registered policy (attached to its version when done)."""
    _submit(url, "export", {"policy": policy, "out": out}, as_json)


@submit_app.command("probe")
def submit_probe(
    episodes: int = typer.Option(5, "--episodes", min=1),
    interval: float = typer.Option(0.1, "--interval", min=0.0, help="Seconds per synthetic episode."),
    url: str = URL,
    as_json: bool = JSON,
) -> None:
    """Queue a diagnostic job (no training) to check the service's workers end to end."""
    _submit(url, "probe", {"episodes": episodes, "interval_s": interval}, as_json)


@app.command("list")
def list_jobs(
    status: str = typer.Option(None, "--status", help="queued | running | succeeded | failed | cancelled."),
    kind: str = typer.Option(None, "--kind", help="train | align | eval | export | probe."),
    limit: int = typer.Option(20, "--limit", min=1, max=500),
    offset: int = typer.Option(0, "--offset", min=0),
    experiment: int = typer.Option(None, "--experiment", min=1, help="Only the cells of this experiment."),
    url: str = URL,
    as_json: bool = JSON,
) -> None:
    """List jobs, newest first (with --experiment ID: that experiment's cells)."""
    with user_errors(), _client(url) as client:
        page = client.list_jobs(
            status=status, kind=kind, offset=offset, limit=limit, experiment_id=experiment
        )
    if as_json:
        typer.echo(json.dumps(page))
        return
    from rich.console import Console
    from rich.table import Table

    title = f"{page['count']} job(s)" + (f" of experiment {experiment}" if experiment else "")
    table = Table("id", "kind", "status", "progress", "attempt", "experiment · cell", "created", title=title)
    for job in page["data"]:
        progress = job["progress"]
        shown = (
            f"{progress['episode']}/{progress['total']}" if progress["total"] else str(progress["episode"])
        )
        cell = job.get("cell")
        place = f"{job['experiment_id']} · {cell['key']}" if job.get("experiment_id") and cell else ""
        table.add_row(
            str(job["id"]),
            job["kind"],
            job["status"],
            shown,
            str(job["attempt"]),
            place,
            job["created_at"][:19],
        )
    Console().print(table)


@app.command("show")
def show_job(job_id: int = typer.Argument(..., min=1), url: str = URL, as_json: bool = JSON) -> None:
    """Show one job."""
    with user_errors(), _client(url) as client:
        job = client.job(job_id)
    if as_json:
        typer.echo(json.dumps(job))
        return
    keys = ("id", "kind", "status", "reason", "attempt", "progress", "experiment_id", "cell", "spec")
    for key in (*keys, "summary", "created_at"):
        typer.echo(f"{key}: {json.dumps(job[key]) if isinstance(job[key], dict | list) else job[key]}")


@app.command("cancel")
def cancel_job(job_id: int = typer.Argument(..., min=1), url: str = URL, as_json: bool = JSON) -> None:
    """Cancel a queued or running job."""
    with user_errors(), _client(url) as client:
        job = client.cancel(job_id)
    if as_json:
        typer.echo(json.dumps({"id": job["id"], "status": job["status"]}))
    else:
        state = job["status"] if job["status"] == "cancelled" else "cancelling"
        typer.echo(f"job {job['id']} {state}")


@app.command("watch")
def watch_job(job_id: int = typer.Argument(..., min=1), url: str = URL) -> None:
    """Follow a job's live progress until it ends (exit 0 if it succeeded, 1 otherwise)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    final: dict[str, Any] = {}
    with (
        user_errors(),
        _client(url) as client,
        Progress(
            TextColumn("job {task.fields[job]} {task.fields[status]}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("return {task.fields[ret]}"),
            TimeElapsedColumn(),
        ) as progress,
    ):
        task = progress.add_task("job", total=None, job=job_id, status="", ret="-")
        for event, data in client.events(job_id):
            if event in ("status", "end"):
                final = data
                if "progress" not in data:  # {"status": "deleted"}: the job went away
                    continue
                total = data["progress"]["total"]
                progress.update(
                    task, total=total, completed=data["progress"]["episode"], status=data["status"]
                )
            elif event == "metric":
                value = data["data"].get("charts/episodic_return")
                shown = f"{value:.3f}" if isinstance(value, int | float) else "-"
                progress.update(task, completed=data["episode"], ret=shown)
    reason = f": {final['reason']}" if final.get("reason") and final.get("status") != "succeeded" else ""
    typer.echo(f"job {job_id} {final.get('status', 'unknown')}{reason}")
    raise typer.Exit(code=0 if final.get("status") == "succeeded" else 1)
