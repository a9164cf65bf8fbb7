"""``scripts/cell_table.py``: on study 5's archived cells it rebuilds the per-run rows docs/results.md
publishes (greedy success, planner share, the models' error against "nothing changes")."""

from __future__ import annotations

from tests.utils.scripts import ROOT, load_script


def test_study_5_rows_match_the_published_table():
    rows = load_script("cell_table").cell_rows(ROOT / "results" / "study5-seen-grasp")
    by_cell = {(r["method"], r["reward"], r["seed"]): r for r in rows}
    assert len(rows) >= 30 and rows[0]["reward"] == "sparse"  # sparse rows first
    i2a = by_cell[("DDPG+I2A", "dense", "1")]
    assert (i2a["greedy success (25 episodes)"], i2a["planner share"],
            i2a["model / no-change error, late half"]) == ("0.44", "0.368", "0.85")
    sac = by_cell[("SAC", "sparse", "1")]
    assert sac["planner share"] == "–" and sac["model / no-change error, late half"] == "–"  # no dual system
    assert by_cell[("DDPG+IM2C", "sparse", "2")]["model / no-change error, late half"] == "2.37"
    published = (ROOT / "docs" / "results.md").read_text()
    for row in rows:  # every row as docs/results.md prints it
        assert "| " + " | ".join(row.values()) + " |" in published
