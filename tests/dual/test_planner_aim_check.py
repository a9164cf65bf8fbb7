"""The aiming planners' controlled check (issue 50): what each aim values per third of ThreeRegions."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import torch

from core.config import load_config
from core.dual.checks.planner_aim import AIMS, CHECK_ENV, aim_signals


def test_aim_signals_report_each_aim_per_third_and_novelty_ranks_the_noise_above_the_learnable_third():
    rows = aim_signals(load_config("default").dual, steps=3000, seed=100, every=1500)
    assert [(row["step"], row["aim"]) for row in rows] == [(s, a) for s in (1500, 3000) for a in AIMS]
    last = {row["aim"]: row for row in rows if row["step"] == 3000}
    for aim, row in last.items():
        values = [row[name] for name in ("trivial", "learnable", "noise")]
        assert all(math.isfinite(v) for v in values), (aim, values)  # uniform visits reach every third
        assert all(0.0 <= v <= 1.0 for v in values), (aim, values)  # each aim is clipped to [0, 1]
    # Prediction error stays high where the outcome is noise and falls where the model learns: the property
    # that draws a novelty planner to a noisy TV.
    assert last["novelty"]["learnable"] < last["novelty"]["noise"]


def test_the_oracle_aim_is_the_learnable_third_and_planning_everywhere_plans_every_step():
    from core.dual.checks.planner_aim import OracleAimWorld, visits
    from core.dual.readings import resolve
    from core.envs.three_regions import REGIONS, ThreeRegionsEnv

    dual = dataclasses.replace(load_config("default").dual, planner="progress")
    regions, planned = visits(dual, steps=300, seed=100, oracle="everywhere")
    assert planned.all() and regions.shape == (300,)
    regions, planned = visits(None, steps=300, seed=100)  # the random walk never plans
    assert not planned.any()
    world = OracleAimWorld(dual, 3, 2, generator=torch.Generator().manual_seed(0), readings=resolve(dual))
    rng = np.random.default_rng(0)
    for point in rng.uniform(-1.0, 1.0, size=(400, 2)):
        world.observe_state(torch.tensor([point[0], point[1], 0.0], dtype=torch.float32))
    field = world.aim_goal("progress")
    region = ThreeRegionsEnv(**CHECK_ENV).region_at(field.centres[:, 0] * field.unit)
    assert set(np.unique(region)) == {0, 1, 2}  # nodes in every region
    np.testing.assert_array_equal(field.values, (region == REGIONS.index("learnable")).astype(float))
    assert field.goal[0] * field.unit < -1.0 / 3.0  # the check's learnable third is the left one


def test_the_checks_learnable_third_is_learnt_in_budget_and_the_noise_third_cannot_be():
    """The check's premise (docs/dual-system.md): under uniform visits the local models learn the learnable
    third's screen well below "nothing changes" within 3 000 steps, while the noise third stays at or above
    the floor of a model of the noise's mean (E(z′ − z̄)² / E(z′ − z)² = (1/3) / (2/3) for uniform screens)."""
    from core.dual.checks.planner_aim import learnability

    rows = learnability(load_config("default").dual, steps=3000, seed=100, every=1500, test_size=2000)
    assert [row["step"] for row in rows] == [1500, 3000]
    assert rows[-1]["learnable"] < 0.4, rows
    assert rows[-1]["noise"] > 0.45, rows


def test_exact_sign_flip_p_counts_every_flip() -> None:
    import pytest

    from core.dual.checks.planner_aim import exact_sign_flip_p

    assert exact_sign_flip_p([0.3] * 5) == 2 / 32  # only all-plus and all-minus reach |mean| 0.3
    assert exact_sign_flip_p([1.0, -1.0, 1.0, -1.0]) == 1.0  # observed mean 0: every flip is as extreme
    assert exact_sign_flip_p([0.5, 0.1, 0.1]) == 2 / 8  # |±0.5 ± 0.1 ± 0.1| reaches 0.7 only unflipped
    assert exact_sign_flip_p([0.5, 0.1, -0.1]) == 6 / 8  # sums 0.5, 0.7, 0.3, 0.5 and their negatives
    with pytest.raises(ValueError, match="at most 20"):
        exact_sign_flip_p([0.1] * 21)


def test_machinery_check_reports_shares_and_paired_comparisons_with_the_walk_of_each_seed() -> None:
    from core.dual.checks.planner_aim import PAIRED, machinery_check

    per_seed: list[dict[str, object]] = []
    out = machinery_check(load_config("default").dual, steps=120, seeds=2, first_seed=100, per_seed=per_seed)
    assert len(per_seed) == 3 * 2 and {row["planner"] for row in per_seed} == {
        "oracle_gated", "oracle_everywhere", "random_walk"}
    walk = [row for row in per_seed if row["planner"] == "random_walk"]
    everywhere = [row for row in per_seed if row["planner"] == "oracle_everywhere"]
    for key in PAIRED:
        expected = np.mean([a[key] - b[key] for a, b in zip(everywhere, walk, strict=True)])
        assert abs(out[f"oracle_everywhere_{key}_minus_walk"] - expected) < 1e-3
        assert 0.0 < out[f"oracle_everywhere_{key}_p"] <= 1.0
    assert out["oracle_everywhere_planned"] == 1.0 and out["random_walk_planned"] == 0.0


def test_the_fixed_start_check_scores_the_noisy_tv_measure_against_the_walk():
    """`fixed_start_check`: each planner alone on the noisy TV from its fixed start, scored with the loop's
    late-half measure (`late_half_measures` on the episodes' own cell masks), beside the random walk of the
    same seed with paired differences; the walk never plans, an aiming planner does."""
    from core.dual.checks.planner_aim import fixed_start_check, fixed_start_measures
    from core.envs.noisy_tv import REST_CELLS

    walk = fixed_start_measures(None, steps=400, seed=100)  # two episodes: the late half is the second
    assert walk["planned"] == 0.0
    assert 1 / REST_CELLS <= walk["coverage_rest"] < 0.5  # the start cell at least; 200 steps cover little
    per_seed: list[dict[str, object]] = []
    figures = fixed_start_check(load_config("default").dual, steps=400, seeds=[100, 101],
                                planners=["babbling"], per_seed=per_seed)
    assert [(row["planner"], row["seed"]) for row in per_seed] == [
        ("babbling", 100), ("babbling", 101), ("random_walk", 100), ("random_walk", 101)]
    assert figures["random_walk_coverage_rest"] == pytest.approx(
        np.mean([row["coverage_rest"] for row in per_seed if row["planner"] == "random_walk"]), abs=1e-4)
    walk_100 = next(row for row in per_seed if row["planner"] == "random_walk" and row["seed"] == 100)
    assert walk_100["coverage_rest"] == walk["coverage_rest"]  # the same seed, the same walk
    pairs = zip(per_seed[:2], per_seed[2:], strict=True)
    differences = [b["coverage_rest"] - w["coverage_rest"] for b, w in pairs]
    assert figures["babbling_coverage_rest_minus_walk"] == pytest.approx(np.mean(differences), abs=1e-4)
    assert 0.0 < figures["babbling_planned"] <= 1.0 and figures["babbling_coverage_rest_p"] <= 1.0


def test_the_published_fixed_start_table_is_what_the_archived_check_printed():
    """docs/results.md's item-20 table: each row's per-seed coverage and mean are the archived output of
    `python -m core.dual.checks.planner_aim fixed … --per-seed` (results/study4-fixed-start-check/), and the
    README's figures from it."""
    import json
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    published = (root / "docs" / "results.md").read_text()
    readme = (root / "README.md").read_text()
    means = {}
    for path in sorted((root / "results" / "study4-fixed-start-check").glob("*.jsonl")):
        commit = path.name.split("-")[0]
        lines = [json.loads(line) for line in path.read_text().splitlines()]
        summary = lines[-1]
        for planner in {row["planner"] for row in lines[:-1]}:
            coverage = [row["coverage_rest"] for row in lines[:-1] if row["planner"] == planner]
            assert summary[f"{planner}_coverage_rest"] == pytest.approx(np.mean(coverage), abs=1e-4)
            cells = " / ".join(f"{value:.3f}" for value in coverage) + f" | {np.mean(coverage):.3f} |"
            assert cells in published, (path.name, planner, cells)
            means[(commit, path.name.split("seeds-")[1][:-6], planner)] = f"{np.mean(coverage):.3f}"
    assert means[("a5ecd29", "100-104", "progress")] == "0.632"
    assert means[("a5ecd29", "105-109", "babbling")] == "0.839"
    fresh = root / "results" / "study4-fixed-start-check" / "8ce8741-seeds-110-119.jsonl"
    lines = [json.loads(line) for line in fresh.read_text().splitlines()]
    noise = {planner: f"{lines[-1][f'{planner}_noise_share']:.3f}" for planner in ("progress", "babbling")}
    assert f"late noise share {noise['progress']} against the babbled goals' {noise['babbling']}" in readme
    aims = root / "results" / "study4-fixed-start-check" / "8ce8741-aims-seeds-110-114.jsonl"
    summary = json.loads(aims.read_text().splitlines()[-1])
    assert f"the disagreement planner's {summary['disagreement_noise_share']:.3f})" in readme
