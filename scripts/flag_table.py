"""One row per finished MountainCar cell: when the flag was first reached, when the greedy policy first
returned ≥ 90, the final greedy return and how many training episodes reached the flag.

Study 4's tuning grid (issue 50) has too few seeds per method for the report's IQMs while it runs; this prints
what each finished cell did, one Markdown row a cell, by seed and then by method name:

    python scripts/flag_table.py results/study4-mountaincar-tuning-63a3ecb
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import typer

from core.experiments.cells import cell_state

COLUMNS = (
    "method", "seed", "first flag (env step)", "first greedy ≥ 90 (env step)",
    "final greedy return (10 episodes)", "training episodes at the flag",
)
"""The table's columns, the keys of :func:`flag_rows`' rows."""

GOAL = 90.0
"""The greedy return that counts as solved (the experiment's ``return_goal``)."""


def _step(value: int | None) -> str:
    return "–" if value is None else f"{value:,}".replace(",", " ")


def flag_rows(experiment_dir: Path) -> list[dict[str, str]]:
    """The rows of every finished cell under ``experiment_dir`` (done as the runner counts it: a summary.json
    of a run that was not stopped; a stopped cell, which resumes, is left out). A training episode reached the
    flag when its return is positive (the +100 outweighs any action cost of 999 steps)."""
    rows = []
    cells = [cell for cell in Path(experiment_dir).glob("*/*/seed-*") if cell_state(cell) == "done"]
    for cell in sorted(cells, key=lambda c: (int(c.name.removeprefix("seed-")), c.parts[-3])):
        with (cell / "metrics.csv").open(newline="") as file:
            episodes = list(csv.DictReader(file))
        flags = [int(e["global_step"]) for e in episodes if float(e["charts/episodic_return"]) > 0]
        evaluated = [e for e in episodes if e.get("eval/return")]
        solved = [int(e["global_step"]) for e in evaluated if float(e["eval/return"]) >= GOAL]
        summary = json.loads((cell / "summary.json").read_text())
        values = (
            cell.parts[-3], cell.name.removeprefix("seed-"), _step(flags[0] if flags else None),
            _step(solved[0] if solved else None), f"{summary['eval_return']:.1f}",
            f"{len(flags)} of {len(episodes)}",
        )
        rows.append(dict(zip(COLUMNS, values, strict=True)))
    return rows


def main(experiment_dir: Path = typer.Argument(..., help="An experiment folder or its archive.")) -> None:
    """Print the Markdown table of every finished cell."""
    typer.echo("| " + " | ".join(COLUMNS) + " |")
    typer.echo("|" + "---|" * len(COLUMNS))
    for row in flag_rows(experiment_dir):
        typer.echo("| " + " | ".join(row.values()) + " |")


if __name__ == "__main__":
    typer.run(main)
