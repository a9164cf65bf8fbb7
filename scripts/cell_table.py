"""One row per finished cell of an experiment: greedy and training success, the planner's share and the
world models' error against "nothing changes".

Study 5 (issue 51) asks per run whether the dual system's premise holds on the seen grasp; ``dualsys
experiment report`` gives those diagnostics only as IQMs over seeds, and a grid still running has too few
seeds for them. This prints the scores the report reads (:func:`core.experiments.report.collect`), one
Markdown row per cell, sparse rows first, by seed and then in the file's order of methods:

    python scripts/cell_table.py results/study5-seen-grasp
"""

from __future__ import annotations

import math
from pathlib import Path

import typer

from core.experiments.report import CellRecord, collect

COLUMNS = (
    "method", "reward", "seed", "greedy success (25 episodes)", "training success (last 500 ep.)",
    "planner share", "model / no-change error, late half", "episode length",
)
"""The table's columns, the keys of :func:`cell_rows`' rows."""


def _number(value: float, digits: int) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def cell_rows(directory: Path | str) -> list[dict[str, str]]:
    """The finished cells of ``directory`` as rows keyed by :data:`COLUMNS`, each value as printed."""
    spec, _, records, _ = collect(directory)
    order = [m.label for m in spec.methods]

    def key(record: CellRecord) -> tuple:
        return (spec.rewards.index(record.reward), record.seed, order.index(record.label))

    rows = []
    for record in sorted(records, key=key):
        s = record.scores
        values = (record.label, record.reward, str(record.seed), _number(s["success"], 2),
                  _number(s["train_success"], 3), _number(s["planner_share"], 3),
                  _number(s["model_error_ratio"], 2), _number(s["train_length"], 1))
        rows.append(dict(zip(COLUMNS, values, strict=True)))
    return rows


def main(directory: Path = typer.Argument(..., help="An experiment folder (OUT/<experiment> or an archive).")
         ) -> None:
    """Print the per-cell table as Markdown."""
    print("| " + " | ".join(COLUMNS) + " |")
    print("|---" * len(COLUMNS) + "|")
    for row in cell_rows(directory):
        print("| " + " | ".join(row.values()) + " |")


if __name__ == "__main__":
    typer.run(main)
