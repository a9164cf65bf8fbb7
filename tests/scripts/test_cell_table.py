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


def test_readme_study_5_row_is_what_the_archive_holds():
    rows = load_script("cell_table").cell_rows(ROOT / "results" / "study5-seen-grasp")
    assert len(rows) == 90
    sparse = [r for r in rows if r["reward"] == "sparse"]
    best = max(sparse, key=lambda r: float(r["greedy success (25 episodes)"]))
    assert len(sparse) == 45 and (best["method"], best["greedy success (25 episodes)"]) == ("DDPG", "0.40")

    def runs_at_least(method: str, reward: str, level: float) -> int:
        return sum(float(r["greedy success (25 episodes)"]) >= level for r in rows
                   if (r["method"], r["reward"]) == (method, reward))

    assert (runs_at_least("DDPG+I2A", "dense", 0.2), runs_at_least("DDPG", "dense", 0.2)) == (2, 0)
    ratios = [float(r["model / no-change error, late half"]) for r in rows
              if r["model / no-change error, late half"] != "–"]
    assert len(ratios) == 40 and min(ratios) >= 0.8
    readme = (ROOT / "README.md").read_text()
    assert "no run of 45 reaches 50 % (the best, DDPG alone, 0.40 on one seed)" in readme
    assert "DDPG+I2A ≥ 0.2 in 2 of 5 runs, DDPG in 0 of 5" in readme
    assert "(error ratio < 0.8) in none of the 40 dual runs" in readme


def test_readme_study_5_im2c_against_ddpg_is_the_exact_sign_flip_test():
    import itertools

    rows = load_script("cell_table").cell_rows(ROOT / "results" / "study5-seen-grasp")
    greedy = {(r["method"], r["reward"], r["seed"]): float(r["greedy success (25 episodes)"]) for r in rows}
    diffs = [greedy[("DDPG+IM2C", "sparse", s)] - greedy[("DDPG", "sparse", s)] for s in "12345"]
    observed = abs(sum(diffs))
    flips = [abs(sum(sign * d for sign, d in zip(signs, diffs, strict=True)))
             for signs in itertools.product((1, -1), repeat=len(diffs))]
    p = sum(total >= observed - 1e-12 for total in flips) / len(flips)
    assert (round(sum(diffs) / len(diffs), 3), round(p, 2)) == (-0.024, 0.88)
    assert "mean −0.024 (exact sign-flip p = 0.88)" in (ROOT / "README.md").read_text()
