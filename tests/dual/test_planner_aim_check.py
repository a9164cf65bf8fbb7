"""The aiming planners' controlled check (issue 50): what each aim values per third of ThreeRegions."""

from __future__ import annotations

import math

from core.config import load_config
from core.dual.checks.planner_aim import AIMS, aim_signals


def test_aim_signals_report_each_aim_per_third_and_novelty_ranks_the_noise_above_the_trivial_third():
    rows = aim_signals(load_config("default").dual, steps=2000, seed=100, every=1000)
    assert [(row["step"], row["aim"]) for row in rows] == [(s, a) for s in (1000, 2000) for a in AIMS]
    last = {row["aim"]: row for row in rows if row["step"] == 2000}
    for aim, row in last.items():
        values = [row[name] for name in ("trivial", "learnable", "noise")]
        assert all(math.isfinite(v) for v in values), (aim, values)  # uniform visits reach every third
        assert all(0.0 <= v <= 1.0 for v in values), (aim, values)  # each aim is clipped to [0, 1]
    # Prediction error stays high where the outcome is noise and falls where nothing changes: the property
    # that draws a novelty planner to a noisy TV.
    assert last["novelty"]["trivial"] < last["novelty"]["noise"]
