"""`core/experiments/noisy_tv_table.py`: the noisy TV's late-half measures gathered per method, finished runs
only, with P against baselines (issue 50, item 4)."""

from __future__ import annotations

import json

import numpy as np

from core.envs.noisy_tv import encode_cells
from core.experiments.noisy_tv_table import main, markdown_header, markdown_rows, method_table
from core.runs.run_dir import MetricsCSV
from tests.utils.scripts import ROOT


def published_table(archive: str, baselines: list[str]) -> dict[str, dict]:
    """`method_table` of results/``archive`` against ``baselines``, after checking that docs/results.md prints
    its header and each of its rows."""
    table = method_table(ROOT / "results" / archive, baselines)
    published = (ROOT / "docs" / "results.md").read_text()
    assert markdown_header(baselines) in published
    for line in markdown_rows(table, baselines):
        assert line in published, line
    return table


def test_method_table_groups_runs_by_method_and_compares_each_with_the_baselines(tmp_path, capsys) -> None:
    def run(label: str, seed: int, noise: float, cells: int) -> None:
        visited = np.zeros((15, 15), dtype=bool)
        visited.reshape(-1)[:cells] = True  # the first `cells` cells by column: all rest cells for ≤ 150
        metrics = MetricsCSV(tmp_path / "exp" / label / "task" / f"seed-{seed}" / "metrics.csv")
        metrics.append({"episode": 1, "global_step": 400, "charts/length": 200, "env/noise_share": noise,
                        "env/coverage_rest": 0.0, **encode_cells(visited)})
        if label != "running":  # a run writes summary.json when it ends, normally or stopped part-way
            (metrics.path.parent / "summary.json").write_text(json.dumps({"stopped": label == "stopped"}))

    for seed, (noise, cells) in enumerate([(0.0, 90), (0.1, 60)]):
        run("aimed", seed, noise, cells)
    for seed, (noise, cells) in enumerate([(0.8, 30), (0.9, 15)]):
        run("drawn", seed, noise, cells)
    run("running", 0, 1.0, 1)  # no summary.json yet: a cell still running is left out
    run("stopped", 0, 1.0, 1)  # stopped part-way (it resumes): left out too
    table = method_table(tmp_path / "exp", baselines=["drawn", "absent"])
    assert table["aimed"]["seeds"] == [0, 1] and table["aimed"]["coverage_rest"] == [90 / 150, 60 / 150]
    assert table["aimed"]["noise_share"] == [0.0, 0.1]
    # every aimed run is off the noise and covers more than every drawn run: P = 1 both ways
    assert table["aimed"]["P(less noise than drawn)"]["p"] == 1.0
    assert table["aimed"]["P(more coverage than drawn)"]["p"] == 1.0
    # no comparison with itself, nor with a label that has no runs
    assert not any("absent" in key for key in table["aimed"])
    assert not any("than drawn" in key for key in table["drawn"])
    assert main([str(tmp_path / "exp"), "drawn"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [line["method"] for line in lines] == ["aimed", "drawn"]  # not "running" nor "stopped"
    assert main([]) == 2
    figure = tmp_path / "figures" / "noisy-tv.png"
    assert main([str(tmp_path / "exp"), "drawn", "--figure", str(figure)]) == 0
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"  # the scatter, beside the same JSON lines
    assert [json.loads(line)["method"] for line in capsys.readouterr().out.splitlines()] == ["aimed", "drawn"]
    assert main([str(tmp_path / "exp"), "--figure"]) == 2  # no path given


def test_study_4_noisy_tv_table_is_what_the_archive_gives():
    """docs/results.md's study-4 noisy-TV table of 63a3ecb is the command's output on the archived grid."""
    table = published_table("study4-noisy-tv-tuning-63a3ecb", ["SAC", "SAC+RND"])
    assert sorted(table) == ["SAC", "SAC+IM2C", "SAC+IM2C-disagreement", "SAC+IM2C-progress", "SAC+RND"]
    assert all(row["seeds"] == [100, 101, 102, 103, 104] for row in table.values())
    progress = table["SAC+IM2C-progress"]
    assert progress["noise_share"] == [0.0] * 5  # never at the noise
    assert sum(v > 0.05 for v in table["SAC+RND"]["noise_share"]) == 4  # RND drawn to it in 4 of 5
    assert f"{progress['coverage_rest_iqm']['iqm']:.3f}" == "0.171"


def test_study_4_noisy_tv_table_of_a5ecd29s_babbling_is_what_the_archive_gives():
    """docs/results.md's table of the noisy-TV tuning cells with a5ecd29's goal babbling is the command's
    output on results/study4-noisy-tv-tuning-a5ecd29: the baselines' cells carried over, the aiming planners'
    rerun."""
    table = published_table("study4-noisy-tv-tuning-a5ecd29", ["SAC", "SAC+RND"])
    assert {"SAC", "SAC+RND", "SAC+IM2C-progress", "SAC+IM2C-babbling"} <= set(table)
    assert table["SAC"]["seeds"] == [100, 101, 102, 103, 104]


def test_study_4_noisy_tv_table_of_items_21_22_is_what_the_archive_gives():
    """docs/results.md's item-22 table (every tuning cell of 8ce8741's babbling, the ablations on top of pink
    noise beside it) is the command's output on results/study4-noisy-tv-tuning-8ce8741, against SAC, SAC+RND
    and SAC-pink; the README's figures are from it."""
    table = published_table("study4-noisy-tv-tuning-8ce8741", ["SAC", "SAC+RND", "SAC-pink"])
    assert sorted(table) == ["SAC", "SAC+IM2C", "SAC+IM2C-babbling", "SAC+IM2C-disagreement",
                             "SAC+IM2C-progress", "SAC+RND", "SAC-pink", "SAC-pink+IM2C",
                             "SAC-pink+IM2C-babbling", "SAC-pink+IM2C-progress"]
    assert all(row["seeds"] == [100, 101, 102, 103, 104] for row in table.values())
    iqm = {label: f"{row['coverage_rest_iqm']['iqm']:.3f}" for label, row in table.items()}
    noise = {label: f"{row['noise_share_iqm']['iqm']:.3f}" for label, row in table.items()}
    readme = (ROOT / "README.md").read_text()
    assert f"coverage {iqm['SAC+IM2C-progress']} against SAC's {iqm['SAC']}" in readme
    assert f"the babbled goals alone, covers as much ({iqm['SAC+IM2C-babbling']})" in readme
    assert f"the noisy TV's coverage {iqm['SAC-pink']}" in readme
    assert (f"late noise share {noise['SAC-pink+IM2C-progress']} against pink alone's {noise['SAC-pink']}"
            in readme)
    assert table["SAC+IM2C-progress"]["noise_share"] == [0.0] * 5
    pink, progress = table["SAC-pink"]["noise_share"], table["SAC-pink+IM2C-progress"]["noise_share"]
    assert sum(p < q for p, q in zip(progress, pink, strict=True)) == 4  # "lower on 4 of 5 seeds"


def test_item_23s_noisy_tv_table_is_what_the_archive_gives():
    """docs/results.md's item-23 table (the value at the plan's end, 9d0074a, beside the carried-over cells no
    planner reading touches) is the command's output on results/study4-noisy-tv-tuning-9d0074a; the README's
    figures are from it: the value costs coverage against pink alone on every seed."""
    table = published_table("study4-noisy-tv-tuning-9d0074a", ["SAC", "SAC+RND", "SAC-pink"])
    assert {"SAC-pink+IM2C-progress", "SAC-pink+IM2C-value", "SAC-pink"} <= set(table)
    assert "SAC+IM2C-progress" not in table  # the 8ce8741 cells are item 22's archive
    pink = table["SAC-pink"]["coverage_rest"]
    for label in ("SAC-pink+IM2C-progress", "SAC-pink+IM2C-value"):
        assert table[label]["seeds"] == [100, 101, 102, 103, 104]
        assert all(c < p for c, p in zip(table[label]["coverage_rest"], pink, strict=True))
    iqm = {label: f"{row['coverage_rest_iqm']['iqm']:.3f}" for label, row in table.items()}
    readme = (ROOT / "README.md").read_text()
    progress, alone = iqm["SAC-pink+IM2C-progress"], iqm["SAC-pink"]
    assert f"progress planner on pink {progress} against pink's {alone}" in readme


def test_item_24s_noisy_tv_table_is_what_the_archive_gives():
    """docs/results.md's item-24 table is the command's output on the live archive
    results/study4-noisy-tv-tuning (the 8ce8741 aiming cells carried over, the new c and RND scales beside
    them); the frozen c = 0.1 planner on pink is item 22's: less late noise than pink alone on 4 of 5
    seeds."""
    table = published_table("study4-noisy-tv-tuning", ["SAC", "SAC+RND", "SAC-pink"])
    assert {"SAC-pink+IM2C-progress", "SAC-pink+IM2C-progress-0.5", "SAC-pink+IM2C-progress-2",
            "SAC+RND-0.1", "SAC+RND-2"} <= set(table)
    pink, frozen = table["SAC-pink"]["noise_share"], table["SAC-pink+IM2C-progress"]["noise_share"]
    assert sum(q < p for q, p in zip(frozen, pink, strict=True)) == 4
