"""``scripts/flag_table.py``: on study 4's archived MountainCar tuning cells it rebuilds the rows
docs/results.md publishes (first flag, first greedy ≥ 90, final greedy return, episodes at the flag)."""

from __future__ import annotations

from tests.utils.scripts import ROOT, load_script


def test_study_4_mountaincar_rows_match_the_published_table():
    rows = load_script("flag_table").flag_rows(ROOT / "results" / "study4-mountaincar-tuning")
    by_cell = {(r["method"], r["seed"]): r for r in rows}
    progress = by_cell[("SAC+IM2C-progress-0.1", "100")]
    assert (progress["first flag (env step)"], progress["first greedy ≥ 90 (env step)"]) == ("2 871", "8 519")
    assert by_cell[("SAC+IM2C-progress-0.5", "100")]["first flag (env step)"] == "4 747"
    published = (ROOT / "docs" / "results.md").read_text()
    for row in rows:  # every row as docs/results.md prints it
        assert "| " + " | ".join(row.values()) + " |" in published
