"""`dualsys pairs` and `dualsys align`: paired sim/real images and the sim-to-real encoder alignment.

`align --policy` takes a run directory/checkpoint or a registry reference (resolved here, see
`dualsys_cli.deploy.resolve_policy`). Registration of the aligned policy (decision):

* policy from the registry (`NAME@V`): the aligned run becomes the next version of `--name` (default NAME)
  with parent `NAME@V`;
* policy given as a path with `--name NEW`: the source run directory is registered first as a version of
  NEW (tag `role=source`), then the aligned run as the next version with that one as parent, so the lineage
  is complete; a loose checkpoint file outside a run directory is not registered, and the aligned version
  then has no parent;
* path without `--name`: nothing is registered.
"""

from __future__ import annotations

import json
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from dualsys_cli.deploy import ARTIFACTS, DB, POLICY, open_registry, resolve_policy
from dualsys_cli.errors import user_errors
from dualsys_cli.train import DEFAULT_RUNS_DIR


class _LazyProgress:
    """A progress bar that appears at the first update, so input errors print alone on one line."""

    def __init__(self, description: str, total: int) -> None:
        self.description, self.total = description, total
        self.progress: Progress | None = None

    def update(self, completed: int, stats: str = "") -> None:
        if self.progress is None:
            self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                                     MofNCompleteColumn(), TimeElapsedColumn(),
                                     TextColumn("{task.fields[stats]}"), console=Console(stderr=True))
            self.progress.start()
            self.task = self.progress.add_task(self.description, total=self.total, stats="")
        self.progress.update(self.task, completed=completed, stats=stats)

    def __enter__(self) -> _LazyProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.progress is not None:
            self.progress.stop()


def pairs_command(
    n: int = typer.Option(2000, "--n", min=1, help="Number of image pairs (Section 4.2: 2000)."),
    out: Path = typer.Option(..., "--out", help="Folder to create: sim/NAME.png, real/NAME.png, manifest."),
    shift: Path = typer.Option(None, "--shift", help="YAML/JSON CameraShift of the real-camera stand-in."),
    seed: int = typer.Option(0, "--seed", help="Seed of the states (and the stand-in's sensor noise)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Render paired images of the same states from the sim camera and the real-camera stand-in."""
    from sim2real import generate_pairs, read_camera_shift

    with user_errors():
        camera_shift = read_camera_shift(shift) if shift is not None else None
        with _LazyProgress("pairs", n) as progress:
            report = generate_pairs(n=n, out=out, seed=seed, camera_shift=camera_shift,
                                    on_image=progress.update)
    if as_json:
        typer.echo(json.dumps(report.to_dict()))
    else:
        typer.echo(f"wrote {report.count} pairs to {report.out} (mean |sim − real| = "
                   f"{report.mean_abs_pixel_diff:.1f} grey levels)")


def _source_run_dir(path: Path) -> Path | None:
    """The run directory a policy path belongs to (itself, or RUN for RUN/checkpoints/X.pt), if any."""
    if path.is_dir():
        return path
    if path.parent.name == "checkpoints":
        return path.parent.parent
    return None


def _register(report: Any, resolved: Any, name: str | None, db: Path | None,
              artifacts: Path | None) -> dict[str, Any]:
    """Register the aligned run (see the module docstring); returns what was registered."""
    from registry import PolicyRegistry, RegistrySettings, parse_policy_ref
    from registry.settings import sqlite_url

    if resolved.ref is not None:
        registry = open_registry(db, artifacts)
        target, parent = name or parse_policy_ref(resolved.ref).name, resolved.ref
    else:
        given: dict[str, Any] = {"database_url": sqlite_url(db) if db else None, "artifacts": artifacts}
        registry = PolicyRegistry.from_settings(
            RegistrySettings(**{k: v for k, v in given.items() if v is not None}))
        target, parent = name, None
        source_dir = _source_run_dir(resolved.path)
        if source_dir is not None:
            parent = registry.register_run(target, source_dir, tags={"role": "source"}).ref
    try:
        tags = {"aligned": "true", "role": "aligned",
                "heldout_distance_before": f"{report.heldout_distance_before:.4g}",
                "heldout_distance_after": f"{report.heldout_distance_after:.4g}"}
        description = f"sim-to-real aligned encoder of {parent or resolved.path}"
        version = registry.register_run(target, report.out_dir, parent=parent, tags=tags,
                                        description=description)
    finally:
        registry.database.dispose()
    return {"registered": version.ref, "parent": parent}


def align_command(
    policy: str = POLICY,
    pairs: Path = typer.Option(..., "--pairs", help="Paired-image folder (sim/, real/)."),
    epochs: int = typer.Option(200, "--epochs", min=1, help="Epochs (Section 4.2: 200)."),
    batch_size: int = typer.Option(512, "--batch-size", min=1, help="Batch size (Section 4.2: 512)."),
    lr: float = typer.Option(1e-3, "--lr", help="Adam learning rate of the encoder."),
    holdout: float = typer.Option(0.1, "--holdout", help="Fraction of pairs held out for the report."),
    seed: int = typer.Option(0, "--seed", help="Seed of the split and the batch order."),
    name: str = typer.Option(None, "--name", help="Register the aligned policy under this name."),
    out: Path = typer.Option(None, "--out", help="New run dir [./dualsys-runs/<src>-aligned-<time>]."),
    db: Path = DB,
    artifacts: Path = ARTIFACTS,
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Train the encoder so f(s_real) matches a frozen copy's f(s_sim) (L_Transfer, Section 4.2)."""
    from registry.references import check_policy_name
    from sim2real import align_encoder

    with user_errors():
        if name is not None:
            check_policy_name(name)
        resolved = resolve_policy(policy, db, artifacts)
        if resolved.path.suffix == ".onnx":
            raise ValueError(f"{resolved.path} is an ONNX file; alignment needs a PyTorch checkpoint")
        if out is None:
            stem = (resolved.ref or resolved.path.name).replace("@", "-v")
            out = DEFAULT_RUNS_DIR / f"{stem}-aligned-{time.strftime('%Y%m%d-%H%M%S')}"
        with _LazyProgress("align", epochs) as progress:

            def show(record: Any) -> None:
                progress.update(record.epoch, f"loss {record.train_loss:.4f} · held-out distance "
                                              f"{record.heldout_distance:.4f}")

            report = align_encoder(policy_path=resolved.path, pairs_dir=pairs, out_dir=out, epochs=epochs,
                                   batch_size=batch_size, lr=lr, holdout=holdout, seed=seed,
                                   command=shlex.join(["dualsys", *sys.argv[1:]]), on_epoch=show)
        registered: dict[str, Any] = {"registered": None, "parent": None}
        if resolved.ref is not None or name is not None:
            registered = _register(report, resolved, name, db, artifacts)
    if as_json:
        typer.echo(json.dumps({**report.to_dict(), **registered}))
        return
    typer.echo(f"held-out latent distance ‖φ_sim − φ_real‖: {report.heldout_distance_before:.4f} before → "
               f"{report.heldout_distance_after:.4f} after ({report.heldout_pairs} held-out pairs of "
               f"{report.pairs})")
    typer.echo(f"held-out action difference |μ(φ_sim) − μ(φ_real)|: {report.heldout_action_diff_before:.4f} "
               f"→ {report.heldout_action_diff_after:.4f}")
    typer.echo(f"aligned policy written to {report.out_dir}")
    if registered["registered"]:
        typer.echo(f"registered {registered['registered']} (parent {registered['parent'] or '-'})")
