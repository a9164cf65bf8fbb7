"""`dualsys experiment run|report`: multi-seed comparison grids (parse, call core.experiments, print).

``run FILE`` trains every (method, reward, seed) cell of an experiment file into
``OUT/<experiment>/<label>/<reward>/seed-<s>/`` on local worker processes or a Ray cluster, with one live
progress display; running it again skips finished cells and resumes interrupted ones. ``report DIR``
writes report.md and the figures (docs/experiments.md).
"""

from __future__ import annotations

import contextlib
import json
import math
import signal
import time
from pathlib import Path
from typing import Any

import typer
from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

from dualsys_cli.errors import user_errors

app = typer.Typer(
    help="Experiment grids (methods × reward modes × seeds): run them in parallel, report them.",
    no_args_is_help=True,
)

DEFAULT_OUT = Path("dualsys-experiments")
"""Where experiments go without --out."""

SHIPPED = Path(__file__).resolve().parents[1] / "experiments"
"""The paper's grids (experiments/*.yaml in the repository)."""


def resolve_experiment_file(file: Path) -> Path:
    """``file`` if it exists, else the shipped ``experiments/<file>.yaml`` (``run smoke`` works)."""
    if file.exists() or file.suffix:
        return file
    shipped = SHIPPED / f"{file}.yaml"
    return shipped if shipped.is_file() else file


class _ProgressView:
    """Renders the runner's ExperimentProgress: counts, then one row per running cell."""

    def __init__(self) -> None:
        self.progress: Any = None

    def update(self, progress: Any) -> None:
        self.progress = progress

    def __rich__(self) -> Any:
        progress = self.progress
        if progress is None:
            return Text("starting workers…")
        elapsed = time.monotonic() - progress.started
        header = Text.assemble(
            (f"{progress.experiment}", "bold"),
            f"  {progress.count('done', 'skipped')}/{len(progress.cells)} done",
            f" · {progress.count('running')} running · {progress.count('queued')} queued",
            (f" · {progress.count('failed')} failed", "red") if progress.count("failed") else "",
            (f" · {progress.count('interrupted')} interrupted", "yellow")
            if progress.count("interrupted")
            else "",
            f" · {_minutes(elapsed)}",
        )
        running = progress.running()
        if not running:
            return header
        table = Table(box=None, pad_edge=False, show_header=True, header_style="dim")
        for column in ("cell", "steps", "", "success(100)", "eval", "worker"):
            table.add_column(column)
        for cell in running:
            fraction = min(1.0, cell.step / cell.budget) if cell.budget else 0.0
            bar = "█" * int(fraction * 20) + "░" * (20 - int(fraction * 20))
            table.add_row(
                cell.key,
                f"{cell.step:,}/{cell.budget:,}",
                bar,
                "–" if math.isnan(cell.success) else f"{cell.success:.0%}",
                "–" if math.isnan(cell.eval_success) else f"{cell.eval_success:.0%}",
                cell.worker,
            )
        return Group(header, table)


class _EventLog:
    """The progress of :class:`_ProgressView` for a log (stderr is not a terminal: ``nohup``, a batch job).

    One timestamped line per cell that starts, finishes, fails or is interrupted, and every ``heartbeat_s``
    one line per running cell with its steps, so a background grid's log says where it is."""

    def __init__(self, console: Console, heartbeat_s: float = 600.0) -> None:
        self.console = console
        self.heartbeat_s = heartbeat_s
        self.seen: dict[str, str] = {}
        self.started_at: dict[str, float] = {}
        self.last_heartbeat = time.monotonic()

    def update(self, progress: Any) -> None:
        now = time.monotonic()
        if not self.seen:
            already = progress.count("skipped")
            self._line(progress, f"{len(progress.cells)} cells, {already} already done")
        for key, cell in progress.cells.items():
            before = self.seen.get(key, "queued")
            self.seen[key] = cell.status
            if cell.status == before or cell.status in ("queued", "skipped"):
                continue
            if cell.status == "running":
                self.started_at[key] = now
                self._line(progress, f"{key} started ({cell.worker or 'worker'})")
                continue
            took = now - self.started_at.get(key, now)
            detail = f" at step {cell.step:,} after {_minutes(took)}" if cell.step else ""
            reason = f": {cell.message}" if cell.message else ""
            self._line(progress, f"{key} {cell.status}{detail}{reason}")
        if now - self.last_heartbeat >= self.heartbeat_s:
            self.last_heartbeat = now
            for cell in progress.running():
                self._line(progress, f"{cell.key} at step {cell.step:,}/{cell.budget:,}")

    def _line(self, progress: Any, text: str) -> None:
        counts = f"{progress.count('done', 'skipped')}/{len(progress.cells)} done"
        stamp = time.strftime("%Y-%m-%d %H:%M:%S")
        line = f"{stamp} {progress.experiment} [{counts}] {text}"
        self.console.print(line, markup=False, highlight=False, soft_wrap=True)  # never wrapped


class _ArchiveAsCellsFinish:
    """``--archive-to``: archive the finished cells at the first progress report and whenever one more
    finishes. The first archive fails the run (an archive of another grid is refused before any cell
    trains); a later failure (a full disk) is a warning, and the grid goes on."""

    def __init__(self, show: Any, directory: Path, to: Path, console: Console) -> None:
        self.show, self.directory, self.to, self.console = show, directory, to, console
        self.archived = -1

    def update(self, progress: Any) -> None:
        from core.experiments.archive import archive_experiment

        self.show(progress)
        done = progress.count("done", "skipped")
        if done == self.archived:
            return
        first, self.archived = self.archived < 0, done
        try:
            archive_experiment(self.directory, self.to)
        except OSError as exc:
            if first:
                raise
            self.console.print(f"warning: archiving into {self.to} failed: {exc}", soft_wrap=True)


def _minutes(seconds: float) -> str:
    return f"{int(seconds // 60)}:{int(seconds % 60):02d}"


def _stop_on_ctrl_c_and_term() -> None:
    """Ctrl-C (SIGINT) and SIGTERM stop the grid with every cell resumable, whatever this process inherited:
    a shell that starts a command in the background sets SIGINT to "ignore", which Python would keep, and a
    batch system stops jobs with SIGTERM."""

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, interrupt)


@app.command("run")
def run_command(
    file: Path = typer.Argument(..., help="Experiment file (YAML), or the name of one in experiments/."),
    out: Path = typer.Option(DEFAULT_OUT, "--out", help="Folder of experiments (cells: OUT/<name>/...)."),
    workers: int = typer.Option(
        None, "--workers", min=1, help="Parallel cells (default: the cores here, or the Ray cluster's CPUs)."
    ),
    ray: str = typer.Option(
        None, "--ray", help="Run cells as Ray tasks on this cluster (e.g. 10.0.0.5:6379); OUT must be shared."
    ),
    from_archive: Path = typer.Option(
        None,
        "--from-archive",
        help="First copy the finished cells archived here (TO/<name> of `experiment archive`, or TO) into "
        "OUT where they have not started, so they are skipped: to go on with a grid of which only the "
        "archive was kept. A folder with nothing of this grid yet restores nothing.",
    ),
    archive_to: Path = typer.Option(
        None,
        "--archive-to",
        help="Archive the finished cells into TO/<name> (as `experiment archive --to TO`) at the start and "
        "as each cell finishes, so a machine lost mid-grid loses only the cells in flight.",
    ),
    only: list[str] = typer.Option(
        None,
        "--only",
        help="Run only this method's cells (its label; repeat for several): e.g. the baselines first, while "
        "a method's design is still changing. The other cells are left as they are.",
    ),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line with the outcome."),
) -> None:
    """Run every unfinished cell of an experiment; again, to resume after an interruption."""
    from rich.live import Live

    from core.experiments import load_experiment, run_experiment

    console = Console(stderr=True)
    _stop_on_ctrl_c_and_term()
    with user_errors():
        spec = load_experiment(resolve_experiment_file(file))
        if from_archive is not None:
            from core.experiments.archive import restore_archive

            restored = restore_archive(from_archive, spec, out)
            console.print(f"{len(restored)} finished cells restored from {from_archive}", soft_wrap=True)
        if console.is_terminal:
            view = _ProgressView()
            display: Any = Live(view, console=console, refresh_per_second=4, transient=False)
            on_progress = view.update
        else:
            display, on_progress = contextlib.nullcontext(), _EventLog(console).update
        if archive_to is not None:
            on_progress = _ArchiveAsCellsFinish(on_progress, out / spec.name, archive_to, console).update
        try:
            with display:
                result = run_experiment(
                    spec,
                    out,
                    workers=workers,
                    ray_address=ray,
                    only=only or None,
                    progress_callback=on_progress,
                )
        except KeyboardInterrupt:
            typer.secho(
                "stopped: every cell keeps its latest checkpoint; run the same command again to resume",
                err=True,
                fg=typer.colors.YELLOW,
            )
            raise typer.Exit(code=130) from None
    if as_json:
        typer.echo(json.dumps(result.to_dict()))
    else:
        typer.echo(
            f"{result.directory}: {len(result.done)} cells run, {len(result.skipped)} already done, "
            f"{len(result.failed)} failed, {len(result.interrupted)} interrupted "
            f"({result.wall_s:.0f} s)"
        )
        for key, reason in {**result.failed, **result.interrupted}.items():
            typer.echo(f"  {key}: {reason}")
        if result.complete:
            typer.echo(f"report: dualsys experiment report {result.directory}")
        else:
            typer.echo("run the same command again to resume the unfinished cells")
    if not result.complete:
        raise typer.Exit(code=1)


@app.command("report")
def report_command(
    directory: Path = typer.Argument(..., help="An experiment folder (OUT/<name>)."),
    as_json: bool = typer.Option(False, "--json", help="Print the numbers as one JSON object."),
    reps: int = typer.Option(None, "--reps", min=100, help="Bootstrap replications (default 2000)."),
) -> None:
    """Write report.md, learning_curves.png, success_curves.png and scores.png: IQM with 95% bootstrap CIs,
    mean ± std, probability of improvement over the model-free baseline, Fig. 8-style learning curves."""
    from core.experiments import write_report

    with user_errors():
        report = write_report(directory, reps=reps)
    if as_json:
        typer.echo(json.dumps(_json_ready({k: v for k, v in report.items() if k != "files"})))
        return
    console = Console()
    table = Table(title=f"{report['experiment']}: IQM [95% CI] over seeds")
    for column in ("method", "reward", "seeds", "AuC", "Final Perf", "greedy success"):
        table.add_column(column)
    for label, per_reward in report["methods"].items():
        for reward, entry in per_reward.items():
            table.add_row(
                label,
                reward,
                str(entry["seeds"]),
                *(_interval(entry[metric]) for metric in ("auc", "final_perf", "success")),
            )
    console.print(table)
    typer.echo(f"{report['done']} of {report['cells']} cells finished")
    if report["missing"]:
        typer.echo(f"missing: {', '.join(report['missing'])}")
    for name, path in report["files"].items():
        typer.echo(f"{name}: {path}")


@app.command("archive")
def archive_command(
    directory: Path = typer.Argument(..., help="An experiment folder (OUT/<name>)."),
    to: Path = typer.Option(
        Path("results"), "--to", help="Archives folder (cells land in TO/<name>/, merged with earlier ones)."
    ),
    file: Path = typer.Option(
        None, "--file", help="The experiment file of the cells (default: the folder's, its last run's)."
    ),
) -> None:
    """Copy the numbers of every finished cell (metrics.csv, summary.json, config.yaml; no checkpoints) into
    TO/<name>, small enough for git; `dualsys experiment report TO/<name>` reads it, and a grid run in pieces
    merges into one archive."""
    from core.experiments.archive import archive_experiment

    with user_errors():
        source = resolve_experiment_file(file) if file is not None else None
        result = archive_experiment(directory, to, source)
    typer.echo(f"{result.directory}: {len(result.cells)} finished cells archived")
    typer.echo(f"report: dualsys experiment report {result.directory}")


def _interval(summary: dict[str, Any]) -> str:
    if summary.get("iqm") is None:
        return "–"
    low, high = summary["ci"]
    return f"{summary['iqm']:.3f} [{low:.3f}, {high:.3f}]"


def _json_ready(value: Any) -> Any:
    if isinstance(value, dict):
        return {key: _json_ready(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_json_ready(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
