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
    """Seed 102 has not run, so the rule waits (None); on seeds 100-101 alone it would read: 0.1 kept on one
    seed (101 never reached greedy ≥ 90), 0.5 and 2 on both, 2 sooner."""
    archive = ROOT / "results" / "study4-mountaincar-tuning"
    assert choice.mountaincar_figures(archive) is None
    monkeypatch.setattr(choice, "SEEDS", (100, 101))
    figures = choice.mountaincar_figures(archive)
    assert figures == {0.1: {"kept": 1, "median_first_greedy_90": float("inf")},
                       0.5: {"kept": 2, "median_first_greedy_90": 13188.5},
                       2.0: {"kept": 2, "median_first_greedy_90": 7150.0}}
    assert choice.mountaincar_pick(figures) == 2.0
