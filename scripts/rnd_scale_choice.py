"""RND's scale for study 4's reporting grids, chosen from its tuning cells by the rule written in
docs/dual-system.md ("How RND's scale is chosen", committed in 4e5bfef before its remaining tuning cells ran).

RND gets its best scale per task and per measure, over tuning seeds 100-102 of ``agent.rnd_scale`` ∈
{0.1, 0.5, 2} (labels ``SAC+RND-0.1``, ``SAC+RND`` — the default 0.5 — and ``SAC+RND-2``):

- MountainCar: the most seeds with a final greedy return ≥ 90; ties: the lower median env step of the first
  greedy return ≥ 90 (a seed without one counts as never); then the smaller scale;
- noisy TV, noise: the lowest late noise-share IQM; ties (equal at three decimals): the higher coverage IQM;
- noisy TV, coverage: the highest late coverage IQM; ties: the lower noise-share IQM.

    python scripts/rnd_scale_choice.py results

prints one JSON object: each measure's pick (``null`` while a scale lacks a finished cell on a seed) and the
figures it was read from (a median first greedy ≥ 90 of ``null``: the median seed never reached one).
"""

from __future__ import annotations

import json
import math
import statistics
from pathlib import Path
from typing import Any

import typer

from core.experiments.flag_goals import GOAL, cell_flags, finished_cells
from core.experiments.noisy_tv_table import method_table
from core.experiments.statistics import iqm

SEEDS = (100, 101, 102)
"""The tuning seeds every scale ran."""

NOISY_TV_LABELS = {0.1: "SAC+RND-0.1", 0.5: "SAC+RND", 2.0: "SAC+RND-2"}
"""The tuning grids' label of each scale (0.5, the default, has no suffix on the noisy TV)."""

MOUNTAINCAR_LABELS = {0.1: "SAC+RND-0.1", 0.5: "SAC+RND-0.5", 2.0: "SAC+RND-2"}
"""MountainCar's tuning grid names every scale."""


def mountaincar_figures(experiment_dir: Path) -> dict[float, dict[str, Any]] | None:
    """Per scale: the seeds with a final greedy return ≥ 90 and the median first greedy ≥ 90 (never: inf);
    None while a scale lacks a finished cell on one of :data:`SEEDS`."""
    cells = {(c.parts[-3], int(c.name.removeprefix("seed-"))): c for c in finished_cells(experiment_dir)}
    figures: dict[float, dict[str, Any]] = {}
    for scale, label in MOUNTAINCAR_LABELS.items():
        if any((label, seed) not in cells for seed in SEEDS):
            return None
        flags = [cell_flags(cells[(label, seed)]) for seed in SEEDS]
        figures[scale] = {
            "kept": sum(f["final_greedy"] >= GOAL for f in flags),
            "median_first_greedy_90": statistics.median(
                math.inf if f["first_greedy"] is None else f["first_greedy"] for f in flags),
        }
    return figures


def mountaincar_pick(figures: dict[float, dict[str, Any]]) -> float:
    """Most seeds kept, then the sooner median first greedy ≥ 90, then the smaller scale."""
    return min(figures, key=lambda s: (-figures[s]["kept"], figures[s]["median_first_greedy_90"], s))


def noisy_tv_figures(experiment_dir: Path) -> dict[float, dict[str, float]] | None:
    """Per scale: the late noise-share and coverage IQMs over :data:`SEEDS` (rounded to three decimals, the
    rule's resolution); None while a scale lacks a finished cell on one of them."""
    table = method_table(experiment_dir)
    figures = {}
    for scale, label in NOISY_TV_LABELS.items():
        row = table.get(label)
        if row is None or not set(SEEDS) <= set(row["seeds"]):
            return None
        at = [row["seeds"].index(seed) for seed in SEEDS]
        figures[scale] = {
            "noise_share": round(iqm([row["noise_share"][i] for i in at]), 3),
            "coverage_rest": round(iqm([row["coverage_rest"][i] for i in at]), 3),
        }
    return figures


def noisy_tv_picks(figures: dict[float, dict[str, float]]) -> dict[str, float]:
    """The lowest noise (ties: more coverage) and the highest coverage (ties: less noise)."""
    return {
        "noise": min(figures, key=lambda s: (figures[s]["noise_share"], -figures[s]["coverage_rest"])),
        "coverage": min(figures, key=lambda s: (-figures[s]["coverage_rest"], figures[s]["noise_share"])),
    }


def _json_safe(figures: dict[str, Any]) -> dict[str, Any]:
    """``figures`` with a never-reached median (inf) printed as null: JSON has no infinity."""
    return {key: None if value == math.inf else value for key, value in figures.items()}


def choice(results: Path) -> dict[str, Any]:
    """The picks and their figures from the archives under ``results``."""
    mountaincar = mountaincar_figures(results / "study4-mountaincar-tuning")
    noisy_tv = noisy_tv_figures(results / "study4-noisy-tv-tuning")
    return {
        "mountaincar": {"pick": mountaincar_pick(mountaincar) if mountaincar else None,
                        "figures": {str(k): _json_safe(v) for k, v in (mountaincar or {}).items()}},
        "noisy_tv": {"picks": noisy_tv_picks(noisy_tv) if noisy_tv else None,
                     "figures": {str(k): v for k, v in (noisy_tv or {}).items()}},
    }


def main(results: Path = typer.Argument(Path("results"), help="The folder of the tuning archives.")) -> None:
    """Print RND's picks as one JSON object."""
    typer.echo(json.dumps(choice(results), indent=2, default=str))


if __name__ == "__main__":
    typer.run(main)
