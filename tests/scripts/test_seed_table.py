"""``scripts/seed_table.py``: on grid 1's archived cells it rebuilds the goal counts and P values that
docs/results.md publishes for study 3's MountainCar grid (so the 15-seed table is made the same way)."""

from __future__ import annotations

from tests.utils.scripts import ROOT, load_script


def test_grid_1_goal_counts_and_probabilities_match_the_published_table():
    script = load_script("seed_table")
    rows = script.method_rows(*script.collect(ROOT / "results" / "study3-mountaincar")[:3])
    kept = {label: row["kept ≥ goal"] for label, row in rows.items()}
    assert kept == {
        "SAC": "0 of 5", "SAC+IM2C": "2 of 5", "SAC+I2A": "2 of 5", "SAC+RND": "4 of 5", "TD3": "0 of 5",
        "TD3+IM2C": "0 of 5", "SB3-SAC": "0 of 5", "SB3-SAC-zoo": "5 of 5",
    }
    assert rows["SAC+IM2C"]["P(> baseline)"] == "0.70 [0.50, 0.90]"
    assert rows["SAC+I2A"]["P(> RND)"] == "0.30 [0.00, 0.60]"
    assert rows["SAC+RND"]["P(> RND)"] == "—"  # RND is nobody's peer but the dual methods'
    assert rows["SB3-SAC-zoo"]["first greedy ≥ goal (k)"] == "13.3 [11.6, 16.8]"
    assert rows["SAC"]["planner share"] == "—" and rows["SAC+IM2C"]["planner share"].startswith("0.79")
