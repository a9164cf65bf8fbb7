"""One row per finished MountainCar cell: when the flag was first reached, when the greedy policy first
returned ≥ 90, the final greedy return and how many training episodes reached the flag.

Study 4's tuning grid (issue 50) has too few seeds per method for the report's IQMs while it runs; this prints
what each finished cell did, one Markdown row a cell, by seed and then by method name:

    python scripts/flag_table.py results/study4-mountaincar-tuning-63a3ecb

With ``--late``, a second table: what each finished cell did over the late half of its training (episodes
that ended past half the env steps it ran) — how long its training episodes were, what they returned, and for
the dual methods the planner's share of the decisions and how far its plan moved the actor's action (the mean
of ``dual/plan_action_shift``): does the planner hand the task back to the actor once the flag is found?
"""

from __future__ import annotations

import csv
from pathlib import Path

import typer

from core.experiments.flag_goals import cell_flags, finished_cells, step_text

COLUMNS = (
    "method", "seed", "first flag (env step)", "first greedy ≥ 90 (env step)",
    "final greedy return (10 episodes)", "training episodes at the flag",
)
"""The table's columns, the keys of :func:`flag_rows`' rows."""

def flag_rows(experiment_dir: Path) -> list[dict[str, str]]:
    """The rows of every finished cell under ``experiment_dir`` (done as the runner counts it: a summary.json
    of a run that was not stopped; a stopped cell, which resumes, is left out), read by
    `core.experiments.flag_goals.cell_flags`."""
    rows = []
    for cell in finished_cells(experiment_dir):
        flags = cell_flags(cell)
        values = (
            cell.parts[-3], cell.name.removeprefix("seed-"), step_text(flags["first_flag"]),
            step_text(flags["first_greedy"]), f"{flags['final_greedy']:.1f}",
            f"{flags['flag_episodes']} of {flags['episodes']}",
        )
        rows.append(dict(zip(COLUMNS, values, strict=True)))
    return rows


LATE_COLUMNS = (
    "method", "seed", "late training episodes", "mean length (env steps)", "mean training return",
    "planner's share of decisions", "mean plan shift of the action",
)
"""The columns of :func:`late_rows`."""


def _episodes(cell: Path) -> list[dict[str, str]]:
    with (cell / "metrics.csv").open(newline="") as file:
        return list(csv.DictReader(file))


def late_rows(experiment_dir: Path) -> list[dict[str, str]]:
    """One row per finished cell over the late half of its training (the episodes that ended past half its
    last env step): their number, mean length and mean return, and where the cell ran a dual method, the
    planner's share of the decisions (``dual/mb_decisions`` over ``dual/mb_decisions`` +
    ``dual/mf_decisions``) and the mean of ``dual/plan_action_shift`` over those episodes ("–" otherwise)."""
    rows = []
    for cell in finished_cells(experiment_dir):
        episodes = _episodes(cell)
        half = int(episodes[-1]["global_step"]) / 2
        late = [e for e in episodes if int(e["global_step"]) > half]
        planned = sum(float(e.get("dual/mb_decisions") or 0.0) for e in late)
        decided = planned + sum(float(e.get("dual/mf_decisions") or 0.0) for e in late)
        shifts = [float(e["dual/plan_action_shift"]) for e in late if e.get("dual/plan_action_shift")]
        values = (
            cell.parts[-3], cell.name.removeprefix("seed-"), str(len(late)),
            f"{sum(float(e['charts/length']) for e in late) / len(late):.0f}",
            f"{sum(float(e['charts/episodic_return']) for e in late) / len(late):.1f}",
            f"{planned / decided:.2f}" if decided > 0 else "–",
            f"{sum(shifts) / len(shifts):.2f}" if shifts else "–",
        )
        rows.append(dict(zip(LATE_COLUMNS, values, strict=True)))
    return rows


def _print(columns: tuple[str, ...], rows: list[dict[str, str]]) -> None:
    typer.echo("| " + " | ".join(columns) + " |")
    typer.echo("|" + "---|" * len(columns))
    for row in rows:
        typer.echo("| " + " | ".join(row.values()) + " |")


def main(
    experiment_dir: Path = typer.Argument(..., help="An experiment folder or its archive."),
    late: bool = typer.Option(False, "--late", help="Also the late half's table (late_rows)."),
) -> None:
    """Print the Markdown table of every finished cell (and with --late the late half's)."""
    _print(COLUMNS, flag_rows(experiment_dir))
    if late:
        typer.echo("")
        _print(LATE_COLUMNS, late_rows(experiment_dir))


if __name__ == "__main__":
    typer.run(main)
