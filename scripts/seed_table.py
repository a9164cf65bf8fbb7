"""Per-seed table and goal counts of a finished (or running) experiment with a success signal.

Study 3's MountainCar grids (issue 29) are judged on what ``dualsys experiment report`` gives only as IQMs:
how many runs *kept* a greedy return at or above the file's ``return_goal`` at the end, how many found the
goal at all in training, and when. This prints, from the same cells the report reads
(:func:`core.experiments.report.collect`):

1. one row per method with each seed's final greedy return, the training episodes that reached the goal
   ("flags"), the env step of the first one and of the first greedy evaluation at or above ``return_goal``;
2. per method: greedy return and greedy success, IQM [95 % CI]; runs kept ≥ goal, runs that found it; the
   first greedy ≥ goal (a run that never reached it counts as its budget); P(greedy success > baseline) and
   P(> the RND peer on the same learner); the planner's share of the training steps; the core-minutes;
3. the kept counts split at ``--split`` (seeds ≤ split against the rest), to show whether a subset of seeds
   carried a claim.

    python scripts/seed_table.py results/mountaincar-dual-seeds [--split 5]
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import typer

from core.experiments.cells import cell_dir, read_summary
from core.experiments.report import FIRST_RETURN_GOAL, CellRecord, baselines, collect, peers
from core.experiments.spec import ExperimentSpec
from core.experiments.statistics import probability_of_improvement, score_summary


def _interval(summary: dict, digits: int = 1, scale: float = 1.0) -> str:
    """``IQM [lo, hi]`` of a :func:`score_summary`, each value divided by ``scale``."""
    if summary["iqm"] is None:
        return "—"
    lo, hi = summary["ci"]
    return f"{summary['iqm'] / scale:.{digits}f} [{lo / scale:.{digits}f}, {hi / scale:.{digits}f}]"


def _p(entry: dict) -> str:
    """``P [lo, hi]`` of a :func:`probability_of_improvement`."""
    if entry["p"] is None:
        return "—"
    return f"{entry['p']:.2f} [{entry['ci'][0]:.2f}, {entry['ci'][1]:.2f}]"


def _seed_cell(record: CellRecord, goal: float) -> str:
    """A seed's final greedy return with its flags, first flag and first greedy ≥ goal."""
    final = record.scores["eval_return"]
    flags = int(np.nansum(record.successes))
    if flags == 0:
        return f"{final:.1f} (no flag)"
    first_goal = record.scores.get(FIRST_RETURN_GOAL, math.nan)
    budget = float(record.steps[-1])
    reached = f"never ≥ {goal:g}" if first_goal >= budget else f"≥ {goal:g} at {first_goal / 1000:.1f}k"
    return f"{final:.1f} ({flags} flags, first {record.scores['first_success'] / 1000:.1f}k, {reached})"


def _wall_minutes(root: Path, record: CellRecord) -> float:
    """The cell's training wall time in minutes of one core (summary.json's ``wall_s``)."""
    summary = read_summary(cell_dir(root, record.label, record.reward, record.seed)) or {}
    return float(summary.get("wall_s") or math.nan) / 60.0


def _goal(spec: ExperimentSpec) -> float:
    """The file's ``return_goal``, else 90 (MountainCar's)."""
    return spec.return_goal if spec.return_goal is not None else 90.0


def _kept(cells: list[CellRecord], goal: float) -> str:
    """``k of n``: the runs whose final greedy return is at least ``goal``."""
    return f"{sum(r.scores['eval_return'] >= goal for r in cells)} of {len(cells)}"


def _by_label(spec: ExperimentSpec, records: list[CellRecord]) -> dict[str, list[CellRecord]]:
    """The finished cells of each method, in the file's order of methods."""
    return {m.label: [r for r in records if r.label == m.label] for m in spec.methods}


COLUMNS = (
    "method", "n", "greedy return", "greedy success", "kept ≥ goal", "found a flag",
    "first greedy ≥ goal (k)", "P(> baseline)", "P(> RND)", "planner share", "core-min",
)
"""The columns of the per-method table, the keys of :func:`method_rows`' rows."""


def method_rows(spec: ExperimentSpec, root: Path, records: list[CellRecord]) -> dict[str, dict[str, str]]:
    """One row per method with finished cells (``collect``'s spec, folder and records), keyed by
    :data:`COLUMNS`, each value as printed.

    Greedy success is what the P values compare (the goal counts are about success, and success is the
    report's score of this task); a run is *kept* when its final greedy return is at least ``return_goal``."""
    goal = _goal(spec)
    by_label = _by_label(spec, records)
    base, peer = baselines(spec, records), peers(spec, records)
    rows: dict[str, dict[str, str]] = {}
    for label, cells in by_label.items():
        if not cells:
            continue
        success = np.array([r.scores["success"] for r in cells])
        versus = []
        for other in (base.get(label), peer.get(label)):
            others = [r.scores["success"] for r in by_label.get(other or "", [])]
            versus.append(_p(probability_of_improvement(success, others)) if others else "—")
        shares = [r.scores["planner_share"] for r in cells]
        first_steps = [r.scores.get(FIRST_RETURN_GOAL, math.nan) for r in cells]
        values = (
            label, str(len(cells)), _interval(score_summary([r.scores["eval_return"] for r in cells])),
            _interval(score_summary(success), 2),
            _kept(cells, goal),
            f"{sum(np.nansum(r.successes) > 0 for r in cells)} of {len(cells)}",
            _interval(score_summary(first_steps), 1, 1000), *versus,
            _interval(score_summary(shares), 3) if np.isfinite(shares).any() else "—",
            f"{sum(_wall_minutes(root, r) for r in cells):.0f}",
        )
        rows[label] = dict(zip(COLUMNS, values, strict=True))
    return rows


def main(
    directory: Path = typer.Argument(..., help="An experiment folder (OUT/<experiment> or an archive)."),
    split: int = typer.Option(5, help="Kept counts are also given for seeds ≤ split and > split."),
) -> None:
    """Print the per-seed table and the goal counts of an experiment as Markdown."""
    spec, root, records, missing = collect(directory)
    goal = _goal(spec)
    by_label = _by_label(spec, records)
    print(f"{spec.name}: {len(records)} cells done, {len(missing)} missing\n")
    for label, cells in by_label.items():
        row = "; ".join(f"s{r.seed} {_seed_cell(r, goal)}" for r in sorted(cells, key=lambda r: r.seed))
        print(f"- **{label}**: {row}")
    print("\n| " + " | ".join(COLUMNS) + " |")
    print("|---" * len(COLUMNS) + "|")
    for row in method_rows(spec, root, records).values():
        print("| " + " | ".join(row.values()) + " |")
    print(f"\nKept ≥ {goal:g}, seeds ≤ {split} | seeds > {split}:")
    for label, cells in by_label.items():
        low = [r for r in cells if r.seed <= split]
        high = [r for r in cells if r.seed > split]
        print(f"- {label}: {_kept(low, goal)} | {_kept(high, goal)}")


if __name__ == "__main__":
    typer.run(main)
