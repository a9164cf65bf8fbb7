"""MountainCar's study-4 goals per method of an experiment: kept flags, first greedy ≥ 90, final greedy
return.

Issue 50's MountainCar goals read three things of each finished cell (`cell_flags`):

- **kept**: the final greedy return (the run's last evaluation, 10 episodes; ``summary.json``'s
  ``eval_return``) ≥ the goal (90) — the count is compared with Fisher's exact test, two-sided;
- **first greedy ≥ 90**: the env step of the first evaluation whose mean return reached the goal — its IQM
  over seeds is "sooner"; a seed that never reached it counts at the last env step of the experiment's longest
  finished cell (censored: never is the worst, and two nevers tie — a cell's own last step would rank one
  never before another by a few hundred steps of episode rounding), and the table says how many were
  censored;
- **final greedy return**: IQM with its 95 % bootstrap CI, and P(X > Y) against each baseline.

``python -m core.experiments.flag_goals EXPERIMENT_DIR [BASELINE...] [--markdown]``: one JSON line per
method, or with ``--markdown`` the table docs/results.md prints (study 4's reporting grids).
"""

from __future__ import annotations

import csv
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from scipy.stats import fisher_exact

from core.experiments.cells import cell_state
from core.experiments.statistics import probability_of_improvement, score_summary
from core.experiments.table_output import print_table

GOAL = 90.0
"""The greedy return that counts as solved (the experiments' ``return_goal``)."""


def cell_flags(cell: Path, goal: float = GOAL) -> dict[str, Any]:
    """What one finished MountainCar cell did: the env step of its first training episode with a positive
    return (the flag: +100 outweighs any action cost of 999 steps), of its first evaluation with a mean
    return ≥ ``goal`` (None: never), its final greedy return, its last env step, its training episodes and how
    many of them reached the flag."""
    with (cell / "metrics.csv").open(newline="") as file:
        episodes = list(csv.DictReader(file))
    flags = [int(e["global_step"]) for e in episodes if float(e["charts/episodic_return"]) > 0]
    evaluated = [e for e in episodes if e.get("eval/return")]
    solved = [int(e["global_step"]) for e in evaluated if float(e["eval/return"]) >= goal]
    summary = json.loads((cell / "summary.json").read_text())
    return {
        "first_flag": flags[0] if flags else None,
        "first_greedy": solved[0] if solved else None,
        "final_greedy": float(summary["eval_return"]),
        "last_step": int(episodes[-1]["global_step"]),
        "episodes": len(episodes),
        "flag_episodes": len(flags),
    }


def finished_cells(experiment_dir: Path | str) -> list[Path]:
    """The cells the runner counts as done (``EXP/<label>/<reward>/seed-N``), by seed and then by label."""
    cells = [cell for cell in Path(experiment_dir).glob("*/*/seed-*") if cell_state(cell) == "done"]
    return sorted(cells, key=lambda c: (int(c.name.removeprefix("seed-")), c.parts[-3]))


def method_table(experiment_dir: Path | str, baselines: Sequence[str] = ()) -> dict[str, Any]:
    """Per method (in label order): seeds, per-seed final greedy returns and first greedy ≥ 90 steps, the
    kept count, IQM [95 % CI] of the final greedy return and of the censored first greedy ≥ 90 step (never:
    the longest finished cell's last step, the same for every method); against each baseline with runs:
    P(higher final greedy return), P(sooner first greedy ≥ 90) (censored; ties half) with bootstrap CIs, and
    Fisher's exact two-sided p on the kept counts."""
    runs: dict[str, dict[int, dict[str, Any]]] = {}
    for cell in finished_cells(experiment_dir):
        runs.setdefault(cell.parts[-3], {})[int(cell.name.removeprefix("seed-"))] = cell_flags(cell)
    table: dict[str, Any] = {}
    never_at = max((flags["last_step"] for by_seed in runs.values() for flags in by_seed.values()), default=0)
    censored: dict[str, list[int]] = {}  # first greedy ≥ 90, never at the longest cell's last step
    for label in sorted(runs):
        by_seed = runs[label]
        seeds = sorted(by_seed)
        finals = [by_seed[s]["final_greedy"] for s in seeds]
        firsts = [by_seed[s]["first_greedy"] for s in seeds]
        censored[label] = [never_at if first is None else first for first in firsts]
        table[label] = {
            "seeds": seeds,
            "final_greedy": finals,
            "first_greedy": firsts,
            "kept": sum(f >= GOAL for f in finals),
            "final_greedy_iqm": score_summary(finals),
            "first_greedy_iqm": score_summary(censored[label]),
            "never": sum(f is None for f in firsts),
        }
    for label, row in table.items():
        for baseline in baselines:
            if baseline == label or baseline not in table:
                continue
            other = table[baseline]
            row[f"vs {baseline}"] = {
                "P(higher final greedy return)": probability_of_improvement(
                    row["final_greedy"], other["final_greedy"]),
                "P(sooner first greedy >= 90)": probability_of_improvement(
                    [-v for v in censored[label]], [-v for v in censored[baseline]]),
                "Fisher p (kept)": float(fisher_exact(
                    [[row["kept"], len(row["seeds"]) - row["kept"]],
                     [other["kept"], len(other["seeds"]) - other["kept"]]])[1]),
            }
    return table


def step_text(value: float | None) -> str:
    """An env step as the tables print it: rounded, thousands apart by a space; "–" for never."""
    return "–" if value is None else f"{round(value):,}".replace(",", " ")


def markdown_header(baselines: Sequence[str]) -> str:
    """The header row of `markdown_rows` for these baselines."""
    columns = ["method", "seeds", "kept (final greedy ≥ 90)", "final greedy return, per seed",
               "IQM [95 % CI]", "first greedy ≥ 90 (env step), per seed", "IQM [95 % CI] (never = last step)"]
    for baseline in baselines:
        columns += [f"P(final greedy return > {baseline})", f"P(first greedy ≥ 90 sooner than {baseline})",
                    f"Fisher p (kept) vs {baseline}"]
    return "| " + " | ".join(columns) + " |"


def markdown_rows(table: dict[str, Any], baselines: Sequence[str]) -> list[str]:
    """One markdown row a method of `method_table`: finals to one decimal, steps with thin spaces, P [CI] to
    two decimals, Fisher's p to three; "–" where a baseline has no runs."""

    def probability(entry: dict[str, Any]) -> str:
        return f"{entry['p']:.2f} [{entry['ci'][0]:.2f}, {entry['ci'][1]:.2f}]"

    lines = []
    for label, row in table.items():
        final, first = row["final_greedy_iqm"], row["first_greedy_iqm"]
        cells = [
            label, str(len(row["seeds"])), f"{row['kept']} of {len(row['seeds'])}",
            " / ".join(f"{v:.1f}" for v in row["final_greedy"]),
            f"{final['iqm']:.1f} [{final['ci'][0]:.1f}, {final['ci'][1]:.1f}]",
            " / ".join(map(step_text, row["first_greedy"])),
            f"{step_text(first['iqm'])} [{step_text(first['ci'][0])}, {step_text(first['ci'][1])}]",
        ]
        for baseline in baselines:
            versus = row.get(f"vs {baseline}")
            if versus is None:
                cells += ["–", "–", "–"]
                continue
            cells += [probability(versus["P(higher final greedy return)"]),
                      probability(versus["P(sooner first greedy >= 90)"]), f"{versus['Fisher p (kept)']:.3f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """The command line: `method_table` of EXPERIMENT_DIR against the BASELINE labels."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args:
        print("usage: python -m core.experiments.flag_goals EXPERIMENT_DIR [BASELINE...] [--markdown]",
              file=sys.stderr)
        return 2
    markdown = "--markdown" in args
    args = [arg for arg in args if arg != "--markdown"]
    if not Path(args[0]).is_dir():
        print(f"no experiment folder at {args[0]}", file=sys.stderr)
        return 2
    table = method_table(args[0], args[1:])
    print_table(table, markdown_header(args[1:]), markdown_rows(table, args[1:]), markdown)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
