"""Item 24's choice of c (docs/dual-system.md, item 24; the rule committed in e34ec7f before its cells
finished), applied to the archived tuning cells: c = 0.1, the reading frozen at b383b3c, passes on both tasks,
and it is the smallest c the rule considers — so the frozen reading is what the rule picks from the
archives."""

from __future__ import annotations

from core.experiments.noisy_tv_table import method_table
from tests.utils.scripts import ROOT, load_script

RESULTS = ROOT / "results"
NOISY_TV_LABEL = {0.1: "SAC-pink+IM2C-progress", 0.5: "SAC-pink+IM2C-progress-0.5",
                  2.0: "SAC-pink+IM2C-progress-2"}


def passes_noisy_tv(table: dict, label: str) -> bool:
    """Less late noise than pink alone on ≥ 4 of 5 seeds, and a coverage IQM inside pink's 95 % CI or
    above."""
    pink, row = table["SAC-pink"], table[label]
    if row["seeds"] != pink["seeds"] or len(row["seeds"]) != 5:
        return False
    lower = sum(q < p for q, p in zip(row["noise_share"], pink["noise_share"], strict=True))
    return lower >= 4 and row["coverage_rest_iqm"]["iqm"] >= pink["coverage_rest_iqm"]["ci"][0]


def passes_mountaincar(rows: list[dict[str, str]], c: float) -> bool:
    """The flag kept on 3 of 3 seeds and a greedy return ≥ 90 before pink alone on ≥ 2 of 3."""
    def first_greedy(method: str) -> dict[str, int | None]:
        column = "first greedy ≥ 90 (env step)"
        return {r["seed"]: None if r[column] == "–" else int(r[column].replace(" ", ""))
                for r in rows if r["method"] == method}

    label = f"SAC-pink+IM2C-progress-{c:g}"
    flags = [r for r in rows if r["method"] == label and r["first flag (env step)"] != "–"]
    planner, pink = first_greedy(label), first_greedy("SAC-pink")
    sooner = sum(planner.get(seed) is not None and planner[seed] < pink[seed] for seed in pink)
    return len(flags) == 3 and len(planner) == 3 and sooner >= 2


def test_the_rule_picks_c_0_1_from_the_archives():
    table = method_table(RESULTS / "study4-noisy-tv-tuning", ["SAC-pink"])
    rows = load_script("flag_table").flag_rows(RESULTS / "study4-mountaincar-tuning")
    assert passes_noisy_tv(table, NOISY_TV_LABEL[0.1])
    assert passes_mountaincar(rows, 0.1)
    passing = [c for c in sorted(NOISY_TV_LABEL)
               if passes_noisy_tv(table, NOISY_TV_LABEL[c]) and passes_mountaincar(rows, c)]
    assert passing[0] == 0.1  # the rule's pick: the smallest c that passes both
