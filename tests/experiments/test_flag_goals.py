"""`core.experiments.flag_goals`: MountainCar's study-4 goals read from real archived cells — the kept count,
the first greedy ≥ 90 with never counted at the longest cell's last step, Fisher's exact test on the counts —
and a cell stopped part-way left out."""

from __future__ import annotations

import json
import shutil
from math import comb

from core.experiments.flag_goals import (
    cell_flags,
    finished_cells,
    main,
    markdown_header,
    markdown_rows,
    method_table,
)
from tests.utils.scripts import ROOT

TUNING = ROOT / "results" / "study4-mountaincar-tuning"


def test_a_cell_reads_as_its_metrics_say():
    flags = cell_flags(TUNING / "SAC-pink" / "task" / "seed-100")
    assert (flags["first_greedy"], round(flags["final_greedy"], 1)) == (7212, 94.9)
    assert flags["first_flag"] < flags["first_greedy"] <= flags["last_step"]
    sac = cell_flags(TUNING / "SAC" / "task" / "seed-100")
    assert (sac["first_flag"], sac["first_greedy"], sac["flag_episodes"]) == (None, None, 0)


def test_kept_counts_censoring_and_fishers_p():
    table = method_table(TUNING, ["SAC"])
    pink, sac = table["SAC-pink"], table["SAC"]
    assert (pink["kept"], len(pink["seeds"]), sac["kept"], len(sac["seeds"])) == (3, 3, 0, 1)
    longest = max(cell_flags(cell)["last_step"] for cell in finished_cells(TUNING))
    assert sac["never"] == 1 and sac["first_greedy_iqm"]["iqm"] == longest  # never: the longest cell's end
    # 3 of 3 against 0 of 1: the observed table is the most extreme one, hypergeometric C(3,3)C(1,0)/C(4,3)
    versus = pink["vs SAC"]
    assert abs(versus["Fisher p (kept)"] - comb(3, 3) * comb(1, 0) / comb(4, 3)) < 1e-12
    assert versus["P(higher final greedy return)"]["p"] == 1.0
    assert versus["P(sooner first greedy >= 90)"]["p"] == 1.0
    assert "vs SAC" not in sac


def test_two_seeds_that_never_reached_the_goal_tie(tmp_path):
    """Never is one value for every method (the longest cell's last step), so two nevers tie (P = 0.5) however
    many env steps each cell's last episode happened to end at."""
    for label, cell in (("A", "SAC+RND-0.1/task/seed-102"), ("B", "SAC+RND-0.5/task/seed-102")):
        shutil.copytree(TUNING / cell, tmp_path / label / "task" / "seed-1")
    ends = [cell_flags(tmp_path / label / "task" / "seed-1")["last_step"] for label in "AB"]
    assert ends == [50_345, 50_949]  # A's last episode ended sooner: with its own end it would rank first
    versus = method_table(tmp_path, ["B"])["A"]["vs B"]
    assert versus["P(sooner first greedy >= 90)"]["p"] == 0.5


def test_a_cell_stopped_part_way_is_left_out(tmp_path):
    for seed in (100, 101):
        cell = f"SAC-pink/task/seed-{seed}"
        shutil.copytree(TUNING / cell, tmp_path / cell)
    stopped = tmp_path / "SAC-pink" / "task" / "seed-101" / "summary.json"
    stopped.write_text(json.dumps({**json.loads(stopped.read_text()), "stopped": True}))
    table = method_table(tmp_path)
    assert table["SAC-pink"]["seeds"] == [100]
    assert markdown_rows(table, ["SAC"])[0].endswith("| – | – | – |")  # no runs of the baseline
    assert markdown_header(["SAC"]).count("|") == len(markdown_rows(table, ["SAC"])[0].split(" | ")) + 1


def test_the_command_refuses_a_missing_folder(tmp_path, capsys):
    assert main([str(tmp_path / "nothing")]) == 2
    assert "no experiment folder" in capsys.readouterr().err
