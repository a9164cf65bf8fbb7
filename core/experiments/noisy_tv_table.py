"""The noisy TV's late-half measures per method of an experiment, with IQMs and P against baselines.

Issue 50, item 4: `core.envs.noisy_tv` measures one run (``late/noise_share``, ``late/coverage_rest`` over the
late half of training); this module gathers an experiment folder's finished runs by method and summarises them
with `core.experiments.statistics` (it lives here, not beside the env, because envs sit below experiments).

``python -m core.experiments.noisy_tv_table EXPERIMENT_DIR [BASELINE...] [--markdown] [--figure PNG]``: one
JSON line per method, compared with each BASELINE label (e.g. ``SAC SAC+RND``); with ``--markdown``, the table
docs/results.md prints (study 4); with ``--figure``, also the scatter of
`core.experiments.figures.plot_noisy_tv` (docs/figures/study4-noisy-tv-tuning.png).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from core.envs.noisy_tv import run_measures
from core.experiments.cells import cell_state
from core.experiments.figures import plot_noisy_tv
from core.experiments.statistics import probability_of_improvement, score_summary
from core.experiments.table_output import print_table

MEASURES = ("noise_share", "coverage_rest")
"""The late-half measures of `core.envs.noisy_tv.late_half_measures` a table reports (without ``late/``)."""


def method_table(experiment_dir: Path | str, baselines: Sequence[str] = ()) -> dict[str, Any]:
    """The late-half measures of an experiment folder (``EXP/<label>/<task>/seed-N``), per method.

    Only finished runs count (`core.experiments.cells.cell_state` "done": a summary.json that says the run
    ended normally; a run stopped part-way also writes one, and its half-filled late half would read as nan).
    For each method: its per-seed ``late/noise_share`` and ``late/coverage_rest`` (in seed order), the IQM
    with its 95 % bootstrap CI of each (`core.experiments.statistics.score_summary`), and against each method
    in ``baselines`` that has runs: P(less time at the noise) — P(X < Y) on ``late/noise_share``, ties counted
    half — and P(more coverage) — P(X > Y) on ``late/coverage_rest`` — each with its bootstrap CI
    (`probability_of_improvement`; issue 50's noisy-TV goals: both CIs above 0.5)."""
    root = Path(experiment_dir)
    runs: dict[str, dict[int, dict[str, float]]] = {}
    for metrics in sorted(root.rglob("metrics.csv")):
        run = metrics.parent
        if not run.name.startswith("seed-") or cell_state(run) != "done":
            continue  # not a cell, or one still running or stopped part-way (it resumes)
        label = run.relative_to(root).parts[0]
        runs.setdefault(label, {})[int(run.name.removeprefix("seed-"))] = run_measures(run)
    per_seed = {  # each method's measures in seed order, gathered once
        label: {key: [by_seed[seed][f"late/{key}"] for seed in sorted(by_seed)] for key in MEASURES}
        for label, by_seed in runs.items()
    }
    table: dict[str, Any] = {}
    for label, measures in per_seed.items():
        noise, coverage = measures["noise_share"], measures["coverage_rest"]
        row: dict[str, Any] = {
            "seeds": sorted(runs[label]),
            "noise_share": noise,
            "coverage_rest": coverage,
            "noise_share_iqm": score_summary(noise),
            "coverage_rest_iqm": score_summary(coverage),
        }
        for baseline in baselines:
            if baseline == label or baseline not in per_seed:
                continue
            other = per_seed[baseline]
            row[f"P(less noise than {baseline})"] = probability_of_improvement(
                [-v for v in noise], [-v for v in other["noise_share"]]
            )
            row[f"P(more coverage than {baseline})"] = probability_of_improvement(
                coverage, other["coverage_rest"]
            )
        table[label] = row
    return table


def markdown_header(baselines: Sequence[str]) -> str:
    """The header row of `markdown_rows` for these baselines (docs/results.md, study 4: SAC, SAC+RND)."""
    columns = ["method", "seeds", "late noise share, per seed", "IQM [95 % CI]",
               "late coverage of the rest, per seed", "IQM [95 % CI]"]
    for baseline in baselines:
        columns += [f"P(less noise than {baseline})", f"P(more coverage than {baseline})"]
    return "| " + " | ".join(columns) + " |"


def markdown_rows(table: dict[str, Any], baselines: Sequence[str]) -> list[str]:
    """One markdown row a method of `method_table`: seeds, per-seed values and IQM [CI] of both measures (3
    decimals), then P [CI] (2 decimals) against each baseline in order, "–" where none."""

    def three(value: float) -> str:
        return f"{value:.3f}"

    def summary(entry: dict[str, Any]) -> str:
        return f"{three(entry['iqm'])} [{three(entry['ci'][0])}, {three(entry['ci'][1])}]"

    def probability(row: dict[str, Any], key: str) -> str:
        if key not in row:
            return "–"
        return f"{row[key]['p']:.2f} [{row[key]['ci'][0]:.2f}, {row[key]['ci'][1]:.2f}]"

    lines = []
    for label, row in table.items():
        cells = [
            label,
            str(len(row["seeds"])),
            " / ".join(map(three, row["noise_share"])),
            summary(row["noise_share_iqm"]),
            " / ".join(map(three, row["coverage_rest"])),
            summary(row["coverage_rest_iqm"]),
        ]
        for baseline in baselines:
            cells += [
                probability(row, f"P(less noise than {baseline})"),
                probability(row, f"P(more coverage than {baseline})"),
            ]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """The command line: `method_table` of EXPERIMENT_DIR against the BASELINE labels, a line a method."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args:
        usage = ("usage: python -m core.experiments.noisy_tv_table EXPERIMENT_DIR [BASELINE...] [--markdown]"
                 " [--figure PNG]")
        print(usage, file=sys.stderr)
        return 2
    figure = None
    if "--figure" in args:
        at = args.index("--figure")
        if at + 1 >= len(args):
            print("--figure needs the path of the PNG to write", file=sys.stderr)
            return 2
        figure = Path(args.pop(at + 1))
        args.pop(at)
    markdown = "--markdown" in args
    args = [arg for arg in args if arg != "--markdown"]
    table = method_table(args[0], args[1:])
    if figure is not None:
        plot_noisy_tv(table, figure, title=f"{Path(args[0]).name}: late half, dots seeds, crosses IQMs")
    print_table(table, markdown_header(args[1:]), markdown_rows(table, args[1:]), markdown)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
