"""``scripts/flag_table.py``: on study 4's archived MountainCar tuning cells it rebuilds the rows
docs/results.md publishes (first flag, first greedy ≥ 90, final greedy return, episodes at the flag)."""

from __future__ import annotations

from tests.utils.scripts import ROOT, load_script


def assert_published(rows: list[dict[str, str]]) -> None:
    """Every row of ``rows`` as docs/results.md prints it."""
    published = (ROOT / "docs" / "results.md").read_text()
    for row in rows:
        assert "| " + " | ".join(row.values()) + " |" in published


def test_study_4_mountaincar_rows_match_the_published_table():
    rows = load_script("flag_table").flag_rows(ROOT / "results" / "study4-mountaincar-tuning-63a3ecb")
    by_cell = {(r["method"], r["seed"]): r for r in rows}
    progress = by_cell[("SAC+IM2C-progress-0.1", "100")]
    assert (progress["first flag (env step)"], progress["first greedy ≥ 90 (env step)"]) == ("2 871", "8 519")
    assert by_cell[("SAC+IM2C-progress-0.5", "100")]["first flag (env step)"] == "4 747"
    assert_published(rows)


def test_study_4_mountaincar_figures_of_63a3ecb_are_what_the_archive_holds():
    import json

    archive = ROOT / "results" / "study4-mountaincar-tuning-63a3ecb"
    by_cell = {(r["method"], r["seed"]): r for r in load_script("flag_table").flag_rows(archive)}
    first_flag = {
        c: by_cell[(f"SAC+IM2C-progress-{c}", "100")]["first flag (env step)"] for c in ("0.1", "0.5", "2")
    }
    assert first_flag == {"0.1": "2 871", "0.5": "4 747", "2": "18 972"}
    design = (ROOT / "docs" / "dual-system.md").read_text()
    assert "flag at env step 2 871 / 4 747 / 18 972 for c = 0.1 / 0.5 / 2" in design
    sac = by_cell[("SAC", "100")]  # "SAC alone on the same seed never did in 50k steps"
    assert (sac["first flag (env step)"], sac["training episodes at the flag"]) == ("–", "0 of 51")
    assert json.loads((archive / "SAC" / "task" / "seed-100" / "summary.json").read_text())["steps"] >= 50_000


def test_a_stopped_cell_is_left_out_until_it_finishes(tmp_path):
    """Only cells the runner counts as done get a row: a stopped run's summary.json (it resumes) has none."""
    import json

    for label, stopped in (("finished", False), ("stopped", True)):
        cell = tmp_path / label / "task" / "seed-100"
        cell.mkdir(parents=True)
        (cell / "metrics.csv").write_text(
            "episode,global_step,charts/episodic_return,eval/return\n1,999,-3.0,\n2,1500,95.0,93.0\n")
        summary = {"stopped": stopped, "eval_return": None if stopped else 93.0}
        (cell / "summary.json").write_text(json.dumps(summary))
    rows = load_script("flag_table").flag_rows(tmp_path)
    assert [row["method"] for row in rows] == ["finished"]
    assert rows[0]["first flag (env step)"] == "1 500"
    assert rows[0]["training episodes at the flag"] == "1 of 2"


def test_a5ecd29s_mountaincar_rows_match_the_archive():
    """The live grid's first cells at a5ecd29 (its goal babbling): docs/results.md prints each row."""
    rows = load_script("flag_table").flag_rows(ROOT / "results" / "study4-mountaincar-tuning-a5ecd29")
    by_cell = {(r["method"], r["seed"]): r for r in rows}
    assert by_cell[("SAC-pink", "100")]["first flag (env step)"] == "759"
    assert by_cell[("SAC+IM2C-babbling-0.1", "100")]["first flag (env step)"] == "–"
    assert_published(rows)


def test_the_mountaincar_rows_of_8ce8741_match_the_archive():
    """Items 21-22's MountainCar tables (the peers and the planner on top of pink noise, every tuning cell
    of 8ce8741): docs/results.md prints each row of `scripts/flag_table.py --late` on
    results/study4-mountaincar-tuning-8ce8741, both tables; pink noise on our SAC finds the flag on each
    tuning seed, and over the late half every planner cell decides most steps and moves the actor's action
    by about 0.4."""
    script = load_script("flag_table")
    archive = ROOT / "results" / "study4-mountaincar-tuning-8ce8741"
    rows, late = script.flag_rows(archive), script.late_rows(archive)
    pink = [r for r in rows if r["method"] == "SAC-pink"]
    assert [r["seed"] for r in pink] == ["100", "101", "102"]
    assert all(r["first flag (env step)"] != "–" for r in pink)
    assert_published(rows)
    assert_published(late)
    flags = ", ".join(r["first flag (env step)"] for r in pink)
    assert f"first at env step {flags})" in (ROOT / "README.md").read_text()  # the README's pink figures
    planned = [r for r in late if r["method"].startswith("SAC-pink+IM2C")]
    assert len(planned) == 12
    assert all(float(r["planner's share of decisions"]) >= 0.6 for r in planned)
    assert all(0.4 <= float(r["mean plan shift of the action"]) <= 0.45 for r in planned)


def test_item_23s_mountaincar_rows_match_the_archive():
    """Item 23's MountainCar tables (the value at the plan's end, 9d0074a, beside the carried-over peers):
    docs/results.md prints each row of `scripts/flag_table.py --late` on
    results/study4-mountaincar-tuning-9d0074a; the planner with the aim off reaches greedy >= 90 before pink
    alone on each seed, and no planner cell of this reading moves the actor's action by more than 0.15
    over the late half (8ce8741: 0.42)."""
    script = load_script("flag_table")
    archive = ROOT / "results" / "study4-mountaincar-tuning-9d0074a"
    rows, late = script.flag_rows(archive), script.late_rows(archive)
    assert_published(rows)
    assert_published(late)

    def greedy(method: str) -> list[int]:
        column = "first greedy ≥ 90 (env step)"
        return [int(r[column].replace(" ", "")) for r in rows if r["method"] == method]

    assert len(greedy("SAC-pink+IM2C-value")) == 3
    assert all(v < p for v, p in zip(greedy("SAC-pink+IM2C-value"), greedy("SAC-pink"), strict=True))
    shifts = [float(r["mean plan shift of the action"]) for r in late
              if r["method"] in ("SAC-pink+IM2C-value", "SAC-pink+IM2C-progress-0.5")]
    assert len(shifts) == 6 and max(shifts) <= 0.15


def test_late_rows_average_the_late_half_and_read_the_planner_where_there_is_one(tmp_path):
    """The late half is the episodes that ended past half the last env step; the planner's share is its
    decisions over all decisions; a model-free cell has "–" for both planner columns."""
    import json

    header = "episode,global_step,charts/episodic_return,charts/length,dual/mb_decisions,dual/mf_decisions," \
             "dual/plan_action_shift\n"
    dual = tmp_path / "dual" / "task" / "seed-100"
    free = tmp_path / "free" / "task" / "seed-100"
    for cell, rows in (
        (dual, "1,999,-5.0,999,0,999,\n2,1399,90.0,400,300,100,0.5\n3,1599,96.0,200,200,0,0.1\n"),
        (free, "1,999,-5.0,999,,,\n2,1999,80.0,1000,,,\n"),
    ):
        cell.mkdir(parents=True)
        (cell / "metrics.csv").write_text(header + rows)
        (cell / "summary.json").write_text(json.dumps({"stopped": False, "eval_return": 95.0}))
    rows = {row["method"]: row for row in load_script("flag_table").late_rows(tmp_path)}
    # dual: last step 1 599, half 799.5 -> all three episodes; 500 of 1 599 decisions planned; shifts of the
    # two episodes that planned
    assert rows["dual"]["late training episodes"] == "3"
    assert rows["dual"]["mean length (env steps)"] == f"{(999 + 400 + 200) / 3:.0f}"
    assert rows["dual"]["mean training return"] == f"{(-5.0 + 90.0 + 96.0) / 3:.1f}"
    assert rows["dual"]["planner's share of decisions"] == f"{500 / 1599:.2f}"
    assert rows["dual"]["mean plan shift of the action"] == "0.30"
    # free: last step 1 999, half 999.5 -> the second episode alone
    assert (rows["free"]["late training episodes"], rows["free"]["mean training return"]) == ("1", "80.0")
    free_row = rows["free"]
    assert free_row["planner's share of decisions"] == free_row["mean plan shift of the action"] == "–"


def test_item_24s_mountaincar_rows_match_the_archive():
    """Item 24's MountainCar tables (the value from the first positive reward on, 6c6e4e4): docs/results.md
    prints each row of `scripts/flag_table.py --late` on results/study4-mountaincar-tuning, and the README's
    figures for the frozen c = 0.1 against pink alone are the archive's."""
    script = load_script("flag_table")
    archive = ROOT / "results" / "study4-mountaincar-tuning"
    rows, late = script.flag_rows(archive), script.late_rows(archive)
    assert_published(rows)
    assert_published(late)
    column = "first greedy ≥ 90 (env step)"
    frozen = [r[column] for r in rows if r["method"] == "SAC-pink+IM2C-progress-0.1"]
    pink = [r[column] for r in rows if r["method"] == "SAC-pink"]
    assert len(frozen) == len(pink) == 3
    readme = (ROOT / "README.md").read_text()
    assert f"({', '.join(frozen)} against {', '.join(pink)})" in readme
