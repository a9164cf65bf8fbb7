"""RND's tuned scales (docs/dual-system.md, "How RND's scale is chosen"; the rule committed in 4e5bfef before
its remaining tuning cells ran): the rule applied to the archived tuning cells picks what the reporting grids
run, so a peer's scale cannot drift from its tuning."""

from __future__ import annotations

from core.experiments.spec import read_experiment
from tests.utils.scripts import ROOT, load_script

choice = load_script("rnd_scale_choice")


def _rnd_scales(grid: str) -> set[float]:
    spec = read_experiment(ROOT / "experiments" / f"{grid}.yaml")
    return {float(m.overrides.get("agent.rnd_scale", 0.5)) for m in spec.methods if m.algo == "rnd"}


def test_the_rule_orders_scales_by_its_keys():
    figures = {0.1: {"noise_share": 0.0, "coverage_rest": 0.2},
               0.5: {"noise_share": 0.0, "coverage_rest": 0.3},
               2.0: {"noise_share": 0.4, "coverage_rest": 0.3}}
    assert choice.noisy_tv_picks(figures) == {"noise": 0.5, "coverage": 0.5}  # each tie broken by the other
    kept = {0.1: {"kept": 2, "median_first_greedy_90": 5000},
            0.5: {"kept": 3, "median_first_greedy_90": float("inf")},
            2.0: {"kept": 3, "median_first_greedy_90": 9000}}
    assert choice.mountaincar_pick(kept) == 2.0  # most kept first, then the sooner median


def test_the_noisy_tv_grid_runs_rnds_picks():
    picks = choice.choice(ROOT / "results")["noisy_tv"]["picks"]
    assert picks == {"noise": 0.1, "coverage": 2.0}
    assert _rnd_scales("study4-noisy-tv") == set(picks.values())


def test_mountaincars_figures_are_read_from_the_cells(monkeypatch):
    """All nine cells: 0.1 kept the flag on seed 100 alone, 0.5 on 100 and 101, and 2 — the rule picks 2. With
    0.1 and 0.5 lost on seed 102, 2 was the pick whatever its own seed-102 cell gave (on 100-101 it kept the
    flag on both, sooner than 0.5): the grids gained RND-2 before that cell finished."""
    archive = ROOT / "results" / "study4-mountaincar-tuning"
    figures = choice.mountaincar_figures(archive)
    assert figures is not None and choice.mountaincar_pick(figures) == 2.0
    assert figures == {0.1: {"kept": 1, "median_first_greedy_90": float("inf")},
                       0.5: {"kept": 2, "median_first_greedy_90": 13996},
                       2.0: {"kept": 3, "median_first_greedy_90": 8274}}
    monkeypatch.setattr(choice, "SEEDS", (100, 101))
    figures = choice.mountaincar_figures(archive)
    assert figures == {0.1: {"kept": 1, "median_first_greedy_90": float("inf")},
                       0.5: {"kept": 2, "median_first_greedy_90": 13188.5},
                       2.0: {"kept": 2, "median_first_greedy_90": 7150.0}}
    assert choice.mountaincar_pick(figures) == 2.0


def test_the_reward_grids_run_mountaincars_pick():
    """MountainCar and cartpole (the tasks with a reward) run RND at MountainCar's pick."""
    printed = choice.choice(ROOT / "results")["mountaincar"]
    pick = printed["pick"]
    assert pick == 2.0
    assert printed["figures"]["0.1"]["median_first_greedy_90"] is None  # never, printed as JSON's null
    for grid in ("study4-mountaincar", "study4-cartpole-swingup-sparse"):
        assert _rnd_scales(grid) == {pick}, grid
