"""`dualsys export` and `dualsys eval`: ONNX export and the 8-step grasp-trial evaluator (Section 4.2).

`--policy` takes a run directory, a checkpoint (`.pt`), an exported `.onnx` (eval only), or a registry
reference `NAME`, `NAME@VERSION`, `NAME@ALIAS`, resolved here (the CLI layer) through the registry that
`--db`/`--artifacts` (or `DUALSYS_DATABASE_URL`/`DUALSYS_ARTIFACTS`) point at; `core.deploy` only sees paths.
An existing path wins over a reference of the same spelling.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.table import Table

from dualsys_cli.errors import user_errors

DB = typer.Option(None, "--db", help="Registry SQLite file (default ./dualsys.db or DUALSYS_DATABASE_URL).")
ARTIFACTS = typer.Option(None, "--artifacts", help="Registry artifact root (default ./dualsys-artifacts).")
POLICY = typer.Option(..., "--policy", help="Run directory, checkpoint, or NAME@VERSION / NAME@ALIAS.")


class PolicyNotFoundError(FileNotFoundError):
    """--policy is neither an existing path nor a registered policy."""


@dataclass(frozen=True)
class ResolvedPolicy:
    """Where a --policy argument points."""

    path: Path
    """Run directory, checkpoint or ONNX file to load."""
    ref: str | None
    """``NAME@VERSION`` when the policy came from the registry, else None."""
    onnx: Path | None = None
    """The registry version's ONNX artifact, if it has one."""


def open_registry(db: Path | None, artifacts: Path | None) -> Any:
    """The registry of --db/--artifacts or the settings; refuses to create a database that is not there."""
    from registry import PolicyRegistry, RegistrySettings
    from registry.settings import sqlite_url

    given: dict[str, Any] = {"database_url": sqlite_url(db) if db else None, "artifacts": artifacts}
    settings = RegistrySettings(**{k: v for k, v in given.items() if v is not None})
    url = settings.database_url
    if url.startswith("sqlite:///") and not Path(url.removeprefix("sqlite:///")).is_file():
        raise PolicyNotFoundError(f"no policy registry at {url.removeprefix('sqlite:///')}")
    return PolicyRegistry.from_settings(settings)


def resolve_policy(policy: str, db: Path | None, artifacts: Path | None) -> ResolvedPolicy:
    """An existing path, else a registry reference resolved to its version's checkpoint."""
    from registry import parse_policy_ref
    from registry.errors import InvalidName

    candidate = Path(policy).expanduser()
    if candidate.exists():
        return ResolvedPolicy(path=candidate, ref=None)
    try:
        parse_policy_ref(policy)
    except InvalidName:
        raise PolicyNotFoundError(f"policy {policy!r} not found: no such path, and not a NAME@VERSION "
                                  "reference") from None
    try:
        registry = open_registry(db, artifacts)
    except PolicyNotFoundError as exc:
        raise PolicyNotFoundError(f"policy {policy!r} not found: no such path, and {exc}") from None
    try:
        record = registry.resolve(policy)
    finally:
        registry.database.dispose()
    if record.checkpoint is None and record.onnx is None:
        raise PolicyNotFoundError(f"policy {record.ref} has no checkpoint or ONNX artifact")
    return ResolvedPolicy(path=record.checkpoint or record.onnx, ref=record.ref, onnx=record.onnx)


def export_command(
    policy: str = POLICY,
    out: Path = typer.Option(..., "--out", help="ONNX file to write, e.g. policy.onnx."),
    opset: int = typer.Option(17, "--opset", help="ONNX opset version."),
    seed: int = typer.Option(0, "--seed", help="Seed of the parity-check images."),
    db: Path = DB,
    artifacts: Path = ARTIFACTS,
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Export encoder + actor to ONNX (NicoGrasp: uint8 [N,32,64,3] → [N, action_dim]; another task: its
    observations → actions in its units), checked against PyTorch."""
    from core.deploy import OnnxParityError, export_onnx

    with user_errors():
        resolved = resolve_policy(policy, db, artifacts)
        if resolved.path.suffix == ".onnx":
            raise ValueError(f"{resolved.path} is already an ONNX file; export takes a checkpoint")
        try:
            report = export_onnx(policy_path=resolved.path, out=out, opset=opset, seed=seed)
        except OnnxParityError as exc:
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            raise typer.Exit(code=1) from None
        registered = None
        if resolved.ref is not None:
            registry = open_registry(db, artifacts)
            try:
                registered = registry.add_artifact(resolved.ref, out).ref
            finally:
                registry.database.dispose()
    result = {**report.to_dict(), "registered_artifact_of": registered}
    if as_json:
        typer.echo(json.dumps(result))
        return
    meta = report.metadata
    typer.echo(f"exported {out}  (opset {report.opset}, {report.input_name} {meta['input_dtype']} "
               f"{meta['input_shape']} → {report.output_name} [N, {report.action_dim}])")
    typer.echo(f"parity: max |onnxruntime − PyTorch| = {report.max_abs_diff:.2g} on {report.random_images} "
               f"random + {report.env_images} env inputs, batches {list(report.batch_sizes)}")
    if registered:
        typer.echo(f"stored as an artifact of {registered}")


def _trial_table(report: Any) -> Table:
    table = Table(title=f"grasp trials (≤ {report.max_steps} steps each)")
    for column in ("trial", "seed", "result", "steps", "grasp attempts"):
        table.add_column(column, justify="right" if column != "result" else "left")
    for trial in report.per_trial:
        table.add_row(str(trial.trial), str(trial.seed), trial.outcome, str(trial.steps),
                      str(trial.grasp_attempts))
    return table


def eval_command(
    policy: str = POLICY,
    onnx: bool = typer.Option(False, "--onnx", help="Run the ONNX export with onnxruntime."),
    trials: int = typer.Option(25, "--trials", min=1, help="Grasp trials (Section 4.2: 25)."),
    max_steps: int = typer.Option(8, "--max-steps", min=1, help="Grasp steps per trial (Section 4.2: 8)."),
    domain: str = typer.Option("sim", "--domain", help="Camera: sim | real (the real-camera stand-in)."),
    seed: int = typer.Option(None, "--seed", help="Trial k places the object with seed S+k [500000]."),
    shift: Path = typer.Option(None, "--shift", help="YAML/JSON CameraShift of the real camera."),
    db: Path = DB,
    artifacts: Path = ARTIFACTS,
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """The grasp-trial evaluator: success rate with a 95% Wilson interval. A policy of another gymnasium task
    runs --trials greedy episodes of that task instead (success rate and mean return)."""
    from core.deploy import DEFAULT_TRIAL_SEED, OnnxParityError, evaluate_policy
    from sim2real import read_camera_shift

    with user_errors():
        if domain not in ("sim", "real"):
            raise ValueError(f"unknown domain {domain!r} (choose from sim, real)")
        camera_shift = read_camera_shift(shift) if shift is not None else None
        resolved = resolve_policy(policy, db, artifacts)
        path = resolved.onnx if onnx and resolved.onnx is not None else resolved.path
        console = Console(stderr=True)

        def show(trial: Any) -> None:
            if as_json:
                return
            if hasattr(trial, "outcome"):
                console.print(f"trial {trial.trial}/{trials}: {trial.outcome} after {trial.steps} step(s)")
            else:
                outcome = "success" if trial.success else "no success"
                console.print(f"episode {trial.episode + 1}/{trials}: return {trial.episode_return:.2f}, "
                              f"{outcome}, {trial.steps} steps")

        try:
            report = evaluate_policy(policy_path=path, trials=trials, max_steps=max_steps, domain=domain,
                                     seed=DEFAULT_TRIAL_SEED if seed is None else seed, onnx=onnx,
                                     camera_shift=camera_shift, on_trial=show)
        except OnnxParityError as exc:
            typer.secho(f"error: {exc}", err=True, fg=typer.colors.RED)
            raise typer.Exit(code=1) from None
    if as_json:
        typer.echo(json.dumps(report.to_dict()))
        return
    runtime = "onnxruntime" if onnx or path.suffix == ".onnx" else "PyTorch"
    if hasattr(report, "mean_return"):
        rate = f"{report.successes}/{report.trials} = {report.success_rate:.0%}"
        typer.echo(f"{resolved.ref or resolved.path} ({runtime}): mean return {report.mean_return:.2f} over "
                   f"{report.trials} episodes; {rate} success, 95% Wilson interval "
                   f"[{report.ci_low:.2f}, {report.ci_high:.2f}]")
        return
    Console().print(_trial_table(report))
    typer.echo(f"{resolved.ref or resolved.path} on --domain {domain} ({runtime}): {report.successes}/"
               f"{report.trials} = {report.success_rate:.0%} success, 95% Wilson interval "
               f"[{report.ci_low:.2f}, {report.ci_high:.2f}]")
