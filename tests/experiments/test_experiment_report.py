"""The report's numbers on made-up run directories equal a hand computation; partial experiments list
their missing cells; the files and the --json shape."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from core.experiments import build_report
from core.experiments.report import render_markdown
from core.experiments.spec import ExperimentError, read_experiment
from core.experiments.statistics import _improvement, _trimmed_mean, probability_of_improvement, score_summary
from dualsys_cli.main import app

SEEDS = (0, 1, 2, 3)
# Method "M" (a dual-system method) reaches final reward v in its last 500 episodes after 100 episodes at -1;
# the baseline "B" stays at v - 1. Greedy success per seed is given directly.
FINAL = {"M": [0.1, 0.2, 0.3, 0.9], "B": [-0.9, -0.8, -0.7, -0.1]}
SUCCESS = {"M": [0.2, 0.4, 0.6, 1.0], "B": [0.0, 0.0, 0.2, 0.4]}


def write_cell(
    root: Path,
    label: str,
    reward: str,
    seed: int,
    returns: list[float],
    success: float,
    *,
    stopped: bool = False,
) -> None:
    cell = root / label / reward / f"seed-{seed}"
    (cell / "checkpoints").mkdir(parents=True)
    with (cell / "metrics.csv").open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["episode", "global_step", "charts/episodic_return", "charts/success"])
        for episode, value in enumerate(returns, start=1):
            writer.writerow([episode, 5 * episode, value, int(value > 0)])
    summary = {
        "algo": "im2c" if label == "M" else "ddpg",
        "ac": "ddpg",
        "reward": reward,
        "seed": seed,
        "episodes": len(returns),
        "steps": 5 * len(returns),
        "success_rate": success,
        "eval_return": 10.0 * success,
        "stopped": stopped,
    }
    (cell / "summary.json").write_text(json.dumps(summary))
    (cell / "checkpoints" / "latest.pt").write_bytes(b"")


@pytest.fixture()
def made_up(tmp_path: Path) -> Path:
    root = tmp_path / "made-up"
    root.mkdir()
    spec = {
        "name": "made-up",
        "rewards": ["sparse"],
        "seeds": list(SEEDS),
        "steps": 3000,
        "smoothing": {"sparse": 10},
        "methods": [{"label": "M", "algo": "im2c", "ac": "ddpg"}, {"label": "B", "algo": "ddpg"}],
    }
    (root / "experiment.yaml").write_text(yaml.safe_dump(spec))
    for label in ("M", "B"):
        for seed in SEEDS:
            returns = [-1.0] * 100 + [FINAL[label][seed]] * 500
            write_cell(root, label, "sparse", seed, returns, SUCCESS[label][seed])
    return root


def test_numbers_equal_a_hand_computation(made_up: Path) -> None:
    report = build_report(made_up)
    assert report["cells"] == 8 and report["done"] == 8 and report["missing"] == []
    m = report["methods"]["M"]["sparse"]
    # Final Perf: mean of the last 500 episodes = v; IQM of 4 seeds = mean of the middle two.
    assert m["final_perf"]["iqm"] == pytest.approx((0.2 + 0.3) / 2)
    assert m["final_perf"]["mean"] == pytest.approx(np.mean(FINAL["M"]))
    assert m["final_perf"]["std"] == pytest.approx(np.std(FINAL["M"]))
    # AuC = mean of all 600 rewards = (100·(−1) + 500·v) / 600.
    auc = [(-100 + 500 * v) / 600 for v in FINAL["M"]]
    assert m["auc"]["iqm"] == pytest.approx((auc[1] + auc[2]) / 2)
    assert m["auc"]["mean"] == pytest.approx(np.mean(auc))
    assert m["auc_from_minus1"]["iqm"] == pytest.approx(((auc[1] + 1) / 2 + (auc[2] + 1) / 2) / 2)
    assert m["success"]["iqm"] == pytest.approx(0.5) and m["seeds"] == 4
    # Training success: share of grasps (return > 0 here) among the last 500 training episodes, per seed.
    train = [float(v > 0) for v in FINAL["M"]]
    assert m["train_success"]["mean"] == pytest.approx(np.mean(train))
    assert report["methods"]["B"]["sparse"]["train_success"]["mean"] == 0.0  # every B return is ≤ 0
    # Episode length: the made-up cells log one episode every 5 env steps; a diagnostic, not compared.
    assert m["train_length"]["mean"] == pytest.approx(5.0) and m["train_length"]["iqm"] == pytest.approx(5.0)
    assert "train_length" not in m["prob_improvement"]
    # Greedy return: the final evaluation's mean return (10 × success here); compared with the baseline.
    assert m["eval_return"]["mean"] == pytest.approx(10 * np.mean(SUCCESS["M"]))
    assert m["prob_improvement"]["eval_return"]["p"] == pytest.approx(np.mean(
        [[float(a > b) + 0.5 * float(a == b) for b in SUCCESS["B"]] for a in SUCCESS["M"]]
    ))
    # Steps to first success: M's first positive episode is the 101st (5 steps each); B never succeeds and
    # counts as its whole budget (600 episodes × 5 steps); a diagnostic, not compared.
    assert m["first_success"]["mean"] == pytest.approx(505.0)
    assert report["methods"]["B"]["sparse"]["first_success"]["mean"] == pytest.approx(3000.0)
    assert "first_success" not in m["prob_improvement"]
    for metric in ("auc", "final_perf", "success", "auc_from_minus1"):
        low, high = m[metric]["ci"]
        assert low <= m[metric]["iqm"] <= high
        assert min(FINAL["M"]) - 1 <= low < high <= 1.0
    # B is M's baseline. Every M run beats every B run on Final Perf: P(M > B) = 1. Success, over the
    # 16 pairs: 0.2 beats 2 and ties 1, 0.4 beats 3 and ties 1, 0.6 and 1.0 beat 4 → (2.5+3.5+4+4)/16.
    assert m["baseline"] == "B" and report["methods"]["B"]["sparse"]["baseline"] is None
    assert m["prob_improvement"]["final_perf"]["p"] == pytest.approx(1.0)
    assert m["prob_improvement"]["success"]["p"] == pytest.approx(14 / 16)
    low, high = m["prob_improvement"]["success"]["ci"]
    assert low <= 14 / 16 <= high


def test_fast_statistics_equal_rliables() -> None:
    from rliable import metrics

    rng = np.random.default_rng(0)
    for size in (1, 2, 3, 4, 5, 8, 13):
        x, y = rng.normal(size=(size, 1)), rng.integers(0, 3, size=(size + 1, 1)).astype(float)
        assert _trimmed_mean(x) == pytest.approx(metrics.aggregate_iqm(x))
        assert _improvement(x, y) == pytest.approx(metrics.probability_of_improvement(x, y))
        assert _improvement(y, y) == pytest.approx(metrics.probability_of_improvement(y, y))
    same = score_summary([0.5, 0.5, 0.5])
    assert same["iqm"] == 0.5 and same["ci"] == [0.5, 0.5] and same["std"] == 0.0


def test_bootstrap_cis_do_not_depend_on_numpy_global_state_and_leave_it_alone() -> None:
    # rliable resamples with np.random.choice: a report must not change with whatever seeded NumPy before it
    # (in another process the global state is fresh entropy), nor disturb the caller's global stream.
    x, y = [0.0, 0.014, 0.06, 0.022, 0.076], [0.004, 0.0, 0.002, 0.026, 0.002]
    results = []
    for seed in (1, 2):
        np.random.seed(seed)
        before = np.random.get_state()[1].copy()
        results.append((score_summary(x, reps=500)["ci"], probability_of_improvement(x, y, reps=500)["ci"]))
        assert np.array_equal(np.random.get_state()[1], before)
    assert results[0] == results[1]


def test_partial_experiment_reports_what_exists_and_lists_the_missing(made_up: Path) -> None:
    import shutil

    shutil.rmtree(made_up / "B" / "sparse" / "seed-3")
    stopped = made_up / "M" / "sparse" / "seed-0"
    summary = json.loads((stopped / "summary.json").read_text())
    (stopped / "summary.json").write_text(json.dumps({**summary, "stopped": True}))
    report = build_report(made_up)
    assert report["done"] == 6 and sorted(report["missing"]) == ["B/sparse/seed-3", "M/sparse/seed-0"]
    m = report["methods"]["M"]["sparse"]
    assert m["seeds"] == 3 and m["final_perf"]["mean"] == pytest.approx(np.mean([0.2, 0.3, 0.9]))
    # 3 runs: ⌊0.25·3⌋ = 0 runs trimmed at each end, so the IQM is the mean.
    assert m["final_perf"]["iqm"] == pytest.approx(np.mean([0.2, 0.3, 0.9]))
    assert report["methods"]["B"]["sparse"]["seeds"] == 3


def test_report_files_and_json_cli(made_up: Path) -> None:
    result = CliRunner().invoke(app, ["experiment", "report", str(made_up), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert set(data) >= {"experiment", "cells", "missing", "methods"}
    entry = data["methods"]["M"]["sparse"]
    assert set(entry) >= {"auc", "final_perf", "success", "seeds"}
    assert set(entry["auc"]) >= {"iqm", "ci", "mean", "std"}
    for name in ("report.md", "learning_curves.png", "success_curves.png", "scores.png", "value_traces.png"):
        assert (made_up / name).stat().st_size > 0
    markdown = (made_up / "report.md").read_text()
    assert "| **Sparse reward** |" in markdown and "Probability of improvement" in markdown
    assert "0.250 [" in markdown  # M's Final Perf IQM


def test_report_errors_are_one_line(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["experiment", "report", str(tmp_path)])
    assert result.exit_code == 2 and "holds no experiment.yaml" in result.stderr
    assert result.stderr.strip().count("\n") == 0


def test_learning_curves_share_an_env_step_grid(made_up: Path) -> None:
    from core.experiments.report import collect, learning_curves

    spec, _, records, _ = collect(made_up)
    curves = learning_curves(spec, records, points=30)["sparse"]["M"]
    assert curves["steps"][-1] == 3000 and len(curves["steps"]) == 30
    # At the end, every seed's smoothed reward is its final value v: mean and std over seeds of v.
    assert curves["mean"][-1] == pytest.approx(np.mean(FINAL["M"]))
    assert curves["std"][-1] == pytest.approx(np.std(FINAL["M"]))
    assert np.all(curves["n"] == 4)
    # The success curve: each made-up episode grasps where its return is > 0, so at the end a seed's smoothed
    # share is 1 where v > 0, else 0.
    shares = learning_curves(spec, records, points=30, series="successes")["sparse"]["M"]
    assert shares["mean"][-1] == pytest.approx(np.mean([float(v > 0) for v in FINAL["M"]]))


def test_finding_and_keeping_and_overestimation_diagnostics(tmp_path: Path) -> None:
    """Best greedy return is the best of the periodic and final evaluations; the value gap is the mean of
    start value − discounted return over the last 10 training episodes (the greedy one: over the last 3
    greedy evaluations); the planner share is the model-based decisions over all decisions of the run; the
    model error ratio is the second half's summed model error over its summed no-change error; runs
    without those columns give none; all are diagnostics, never compared with a baseline."""
    root = tmp_path / "diag"
    root.mkdir()
    spec = {"name": "diag", "rewards": ["sparse"], "seeds": [0, 1], "steps": 100,
            "episode_measures": ["env/noise_share"],
            "methods": [{"label": "M", "algo": "im2c", "ac": "td3"}, {"label": "B", "algo": "td3"}]}
    (root / "experiment.yaml").write_text(yaml.safe_dump(spec))
    for seed in (0, 1):
        write_cell(root, "B", "sparse", seed, [0.0] * 20, 0.5)  # no start-value or eval columns
        cell = root / "M" / "sparse" / f"seed-{seed}"
        write_cell(root, "M", "sparse", seed, [0.0] * 20, 0.5)
        with (cell / "metrics.csv").open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(["episode", "global_step", "charts/episodic_return", "charts/success",
                             "eval/return", "charts/start_value", "charts/discounted_return",
                             "env/noise_share", "eval/start_value", "eval/discounted_return",
                             "dual/mb_decisions", "dual/mf_decisions", "dual/model_error",
                             "dual/no_change_error"])
            for episode in range(1, 21):
                found = 90.0 + seed if episode == 10 else ""  # a greedy 90 (seed 1: 91) mid-run, then lost
                value = 100.0 if episode > 10 else 1.0  # the critic's value climbs in the last 10 episodes
                noise = 1.0 if episode <= 10 else 0.1 * seed  # the second half: 0.0 and 0.1
                # greedy evaluations every 4th episode; the last three (12, 16, 20) overvalue by 13, 14, 15
                evaluated = episode % 4 == 0
                greedy_value = 50.0 + episode // 4 if evaluated else ""
                greedy_earned = 40.0 if evaluated else ""
                # the planner decides 3 of 4 steps early, then 1 of 4 (seed 0) or 1 of 5 (seed 1)
                planned, unplanned = (3, 1) if episode <= 10 else (1, 3 + seed)
                # the models lose to "nothing changes" early (error 9 against 1); late, errors 1 and 2
                # (seed 0) or 3 (seed 1) alternate against a no-change error of 4 (sums below)
                model_error = 9.0 if episode <= 10 else (1.0 if episode % 2 else 2.0 + seed)
                no_change = "" if episode == 20 else (1.0 if episode <= 10 else 4.0)  # episode 20 unlogged
                writer.writerow([episode, 5 * episode, 0.0, 0, found, value, 40.0 - seed, noise,
                                 greedy_value, greedy_earned, planned, unplanned, model_error, no_change])
    report = build_report(root)
    m, b = report["methods"]["M"]["sparse"], report["methods"]["B"]["sparse"]
    assert m["best_eval_return"]["mean"] == pytest.approx(90.5)  # periodic 90 / 91 beat the final 5.0
    assert m["eval_return"]["mean"] == pytest.approx(5.0)
    assert m["value_gap"]["mean"] == pytest.approx(np.mean([100 - 40, 100 - 39]))
    assert b["best_eval_return"]["mean"] == pytest.approx(5.0)  # only the final evaluation
    assert b["value_gap"]["n"] == 0 and b["value_gap"]["iqm"] is None
    assert m["greedy_value_gap"]["mean"] == pytest.approx(np.mean([13, 14, 15]))  # the last 3 evaluations
    assert b["greedy_value_gap"]["n"] == 0 and "greedy_value_gap" not in m["prob_improvement"]
    assert "value_gap" not in m["prob_improvement"] and "best_eval_return" not in m["prob_improvement"]
    assert m["planner_share"]["mean"] == pytest.approx(np.mean([40 / 80, 40 / 90]))  # summed over the run
    assert b["planner_share"]["n"] == 0 and "planner_share" not in m["prob_improvement"]
    # episodes 11-19 with both errors: seed 0 → (5·1 + 4·2) / (9·4), seed 1 → (5·1 + 4·3) / (9·4)
    assert m["model_error_ratio"]["mean"] == pytest.approx(np.mean([13 / 36, 17 / 36]))
    assert b["model_error_ratio"]["n"] == 0 and "model_error_ratio" not in m["prob_improvement"]
    # An episode measure: the mean of its second half per run, compared with the baseline where B has it
    assert m["env/noise_share"]["mean"] == pytest.approx(0.05) and m["env/noise_share"]["n"] == 2
    assert b["env/noise_share"]["n"] == 0
    assert "env/noise_share" in m["prob_improvement"]
    markdown = render_markdown(read_experiment(root / "experiment.yaml"), report)
    assert "| `env/noise_share` (second half) IQM [95% CI] |" in markdown


def test_dual_methods_are_also_compared_with_rnd_on_the_same_learner(tmp_path: Path) -> None:
    """P(dual > RND) beside P(dual > learner alone) (issue 29): the peer is the rnd method on the same ac."""
    root = tmp_path / "peer"
    root.mkdir()
    spec = {"name": "peer", "rewards": ["sparse"], "seeds": [0, 1, 2], "steps": 100,
            "methods": [{"label": "B", "algo": "ddpg"}, {"label": "M", "algo": "im2c", "ac": "ddpg"},
                        {"label": "R", "algo": "rnd", "ac": "ddpg"},
                        {"label": "S", "algo": "im2c", "ac": "sac"}]}
    (root / "experiment.yaml").write_text(yaml.safe_dump(spec))
    finals = {"B": [0.0, 0.1, 0.2], "M": [0.5, 0.6, 0.7], "R": [0.55, 0.3, 0.9], "S": [0.0, 0.0, 0.0]}
    for label, values in finals.items():
        for seed, value in enumerate(values):
            write_cell(root, label, "sparse", seed, [value] * 20, 0.5)
    report = build_report(root)
    m = report["methods"]["M"]["sparse"]
    assert m["baseline"] == "B" and m["peer"] == "R"
    assert m["prob_improvement"]["final_perf"]["p"] == pytest.approx(1.0)
    # M's 0.5, 0.6, 0.7 against R's 0.55, 0.3, 0.9: 1 + 2 + 2 wins of 9 pairs
    assert m["prob_over_peer"]["final_perf"]["p"] == pytest.approx(5 / 9)
    assert report["methods"]["S"]["sparse"]["peer"] is None  # no RND on SAC in this file
    assert report["methods"]["R"]["sparse"]["peer"] is None
    assert "prob_over_peer" not in report["methods"]["B"]["sparse"]


def test_steps_to_a_return_goal_count_the_first_greedy_evaluation_that_reached_it(tmp_path: Path) -> None:
    """``return_goal`` (study 3's MountainCar goal): the env step of the first periodic greedy evaluation
    whose return reached the goal, else the budget (also when only the final evaluation, at the end of the
    run, did); a diagnostic, never compared."""
    root = tmp_path / "goal"
    root.mkdir()
    spec = {"name": "goal", "rewards": ["sparse"], "seeds": [0, 1, 2], "steps": 100, "return_goal": 90,
            "methods": [{"label": "M", "algo": "im2c", "ac": "sac"}, {"label": "B", "algo": "sac"}]}
    (root / "experiment.yaml").write_text(yaml.safe_dump(spec))
    periodic = {0: {4: 50.0, 8: 95.0, 12: 20.0}, 1: {4: 89.9}, 2: {}}  # episode -> greedy return
    final = {0: 5.0, 1: 92.0, 2: 89.0}
    for seed in (0, 1, 2):
        write_cell(root, "B", "sparse", seed, [0.0] * 20, 0.0)
        cell = root / "M" / "sparse" / f"seed-{seed}"
        write_cell(root, "M", "sparse", seed, [0.0] * 20, 0.0)
        with (cell / "metrics.csv").open("w", newline="") as file:
            writer = csv.writer(file)
            writer.writerow(["episode", "global_step", "charts/episodic_return", "charts/success",
                             "eval/return"])
            for episode in range(1, 21):
                writer.writerow([episode, 5 * episode, 0.0, 0, periodic[seed].get(episode, "")])
        summary = json.loads((cell / "summary.json").read_text())
        (cell / "summary.json").write_text(json.dumps({**summary, "eval_return": final[seed]}))
    report = build_report(root)
    m, b = report["methods"]["M"]["sparse"], report["methods"]["B"]["sparse"]
    # seed 0: the periodic 95 at episode 8 (step 40); seed 1: only the final 92 (the budget, 100);
    # seed 2: never
    assert m["first_return_goal"]["mean"] == pytest.approx(np.mean([40.0, 100.0, 100.0]))
    assert b["first_return_goal"]["mean"] == pytest.approx(100.0)  # final returns 0.0: never reached
    assert "first_return_goal" not in m["prob_improvement"]
    markdown = render_markdown(read_experiment(root / "experiment.yaml"), report)
    assert "| Steps to greedy return ≥ 90 IQM [95% CI] |" in markdown
    # Without a goal in the file there is no such score, and a goal that is not a number is refused.
    spec.pop("return_goal")
    (root / "experiment.yaml").write_text(yaml.safe_dump(spec))
    assert "first_return_goal" not in build_report(root)["methods"]["M"]["sparse"]
    for bad in ("ninety", True, float("nan")):
        with pytest.raises(ExperimentError, match="return_goal"):
            read_experiment({**spec, "return_goal": bad})
