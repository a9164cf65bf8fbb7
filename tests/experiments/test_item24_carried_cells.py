"""Item 24 (docs/dual-system.md): the cells the live study-4 archives carry over from an earlier reading are
the cells item 24's reading writes. The learner's value joins an aiming planner's plans from the run's first
positive reward on, so a noisy-TV cell (no reward) is its 8ce8741 cell, and a MountainCar cell is its 9d0074a
cell wherever that cell made no model-based decision up to its first flag (the value was never read before it)
— in every column of metrics.csv but the clock."""

from __future__ import annotations

import csv
from pathlib import Path

from tests.utils.scripts import ROOT

CLOCK = {"time/wall_s", "charts/sps"}
AIMING_NOISY_TV = ("SAC+IM2C-progress", "SAC+IM2C-disagreement", "SAC+IM2C-babbling",
                   "SAC-pink+IM2C-progress", "SAC-pink+IM2C-babbling")
RESULTS = ROOT / "results"


def rows(cell: Path) -> list[dict[str, str]]:
    with (cell / "metrics.csv").open() as handle:
        return [{k: v for k, v in row.items() if k not in CLOCK} for row in csv.DictReader(handle)]


def planned_before_first_flag(cell: Path) -> float:
    """Model-based decisions up to and including the episode of the first flag (all of them if none)."""
    decisions = 0.0
    for row in rows(cell):
        decisions += float(row["dual/mb_decisions"] or 0.0)
        if row["charts/success"] == "1":
            break
    return decisions


def test_the_noisy_tv_aiming_cells_are_8ce8741s():
    live, old = RESULTS / "study4-noisy-tv-tuning", RESULTS / "study4-noisy-tv-tuning-8ce8741"
    for label in AIMING_NOISY_TV:
        for seed in range(100, 105):
            cell = Path(label) / "task" / f"seed-{seed}"
            carried = rows(live / cell)
            assert carried == rows(old / cell), cell
            assert all(float(row["charts/episodic_return"]) == 0.0 for row in carried)  # no reward: no value


def test_mountaincar_cells_equal_item_23s_exactly_where_those_planned_nothing_before_the_flag():
    live, old = RESULTS / "study4-mountaincar-tuning", RESULTS / "study4-mountaincar-tuning-9d0074a"
    same, rerun = [], []
    for cell in sorted(live.glob("SAC-pink+IM2C-*/task/seed-*")):
        before = old / cell.relative_to(live)
        if not before.is_dir():
            continue
        equal = rows(cell) == rows(before)
        (same if equal else rerun).append(cell.relative_to(live))
        assert equal == (planned_before_first_flag(before) == 0.0), cell
    assert len(same) >= 4 and len(rerun) >= 2  # seed 100's readings and the aim-off seed 102; seeds 101-102
