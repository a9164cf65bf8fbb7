"""The experiment report: per method and reward mode, the paper's scores with rliable statistics.

Scores of one finished cell, from its run directory:

* ``auc`` — Area under Curve of Section 4.1.2 on the cell's episodic rewards (metrics.csv,
  ``core.runs.metrics.area_under_curve``, baseline 0 as the text defines it); ``auc_from_minus1`` — the same
  area measured from reward −1, the reading that fits the paper's Table 1 (see ``core.runs.metrics``);
* ``final_perf`` — Final Performance: mean episodic reward of the last 500 training episodes;
* ``success`` — the final greedy evaluation's success rate (summary.json ``success_rate``);
* ``eval_return`` — the final greedy evaluation's mean episodic return (summary.json ``eval_return``), the
  score the gymnasium benchmarks publish;
* ``first_success`` — a diagnostic: the env step at which the first training episode succeeded (reached
  the goal, grasped); a cell that never succeeded counts as its whole budget (censored there);
* ``train_length`` — a diagnostic, not a score: the mean length in env steps of the last 500 training
  episodes (from metrics.csv's ``global_step``). On a level where a failed grasp ends the episode, short
  episodes mean the policy closes its hand before it has travelled (docs/results.md).
* ``first_return_goal`` — a diagnostic, only for a file with ``return_goal``: the env step of the first
  periodic greedy evaluation whose mean return reached the goal; a cell where none did (the final
  evaluation at the end of the run included) counts as its whole budget, as ``first_success`` does.
  Study 3's MountainCar goal is stated in it.
* ``best_eval_return`` — a diagnostic: the best greedy return of any evaluation in the run (the periodic ones
  in metrics.csv and the final one). Beside ``eval_return`` it separates *finding* from *keeping*: a run that
  reached the goal and lost it has a high best and a low final.
* ``value_gap`` — a diagnostic: over the last ``VALUE_GAP_EPISODES`` training episodes, the mean of the
  critic's value of the start state minus the discounted return the episode earned (``charts/start_value``,
  ``charts/discounted_return``, logged by our trainer and by the SB3 peers alike). Persistently positive is
  overestimation (issue 28); NaN for runs that do not log them (archives older than the columns).
  The training episodes act with exploration (noise, SAC's sampling, the dual system's planner), so part of
  this gap is the exploration's cost, not the critic's error; and a dual agent's critic learns r_ext + r_int.
* ``greedy_value_gap`` — a diagnostic: the same at the greedy evaluations, over the last
  ``VALUE_GAP_EVALS`` of them (``eval/start_value`` − ``eval/discounted_return``): the critic's value of the
  evaluation starts at the greedy action against what the greedy policy earned from them. For a deterministic
  learner this is exactly the return Q(s₀, μ(s₀)) estimates (SAC's soft Q values its stochastic policy).
* ``planner_share`` — a diagnostic of the dual-system methods: the share of the training steps whose action
  the arbitration gave the model-based system (Alg. 2 lines 12-19: ``dual/mb_decisions`` over
  ``dual/mb_decisions`` + ``dual/mf_decisions``, summed over all training episodes); NaN for a run without
  those columns (the model-free methods, RND).
* ``model_error_ratio`` — a diagnostic of the dual-system methods: the world models' Eq. 8 error over that of
  "nothing changes" (φ̂′ = φ_t, r̂ = 0) on the real transitions of the second half of the training episodes
  (``dual/model_error`` summed over those episodes, over ``dual/no_change_error`` summed over the same
  episodes); below 1 the models predict the latent's motion better than standing still — the dual system's
  premise (issue 51); NaN without those columns.

Measures a file lists under ``episode_measures`` (metrics.csv columns an env writes per episode, e.g. the
noisy TV's ``env/noise_share``) are scores too: per cell, the column's mean over the second half of the
training episodes (NaN where the column is missing), with IQM, CI and P(X > baseline), where higher is not
necessarily better (a share of steps at the noise is better lower).

Per (method, reward mode) over seeds: IQM with a 95% stratified-bootstrap CI, mean ± std
(``core.experiments.statistics``), and each method's probability of improvement over its model-free
baseline (the file's ``baseline``, else the ddpg/cacla method with the same actor update, else the first
ddpg/cacla method). Only finished cells count; the others are listed as missing.

``build_report(dir)`` returns the numbers as one JSON-ready dict; ``write_report(dir)`` also writes
``report.md``, ``learning_curves.png`` (Fig. 8/10/11 style), ``success_curves.png`` and ``scores.png``
into the experiment folder.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from core.experiments.cells import EXPERIMENT_FILE, cell_dir, cell_state, read_summary
from core.experiments.spec import ExperimentError, ExperimentSpec, MethodSpec, read_experiment
from core.runs.metrics import area_under_curve, final_performance, smooth
from core.runs.run_dir import atomic_write_text

METRICS: dict[str, str] = {
    "auc": "AuC",
    "auc_from_minus1": "AuC (from −1)",
    "final_perf": "Final Perf",
    "train_success": "Training success",
    "success": "Greedy success",
    "eval_return": "Greedy return",
    "first_success": "Steps to first success",
    "train_length": "Episode length",
    "best_eval_return": "Best greedy return",
    "value_gap": "Start value − discounted return",
    "greedy_value_gap": "Greedy start value − discounted return",
    "planner_share": "Planner share of training steps",
    "model_error_ratio": "Model error / no-change error (late half)",
}
"""Reported scores and their table names."""
BOOTSTRAPPED = (
    "auc", "final_perf", "train_success", "success", "eval_return", "first_success", "train_length",
    "best_eval_return", "value_gap", "greedy_value_gap", "planner_share", "model_error_ratio",
)
"""Scores with their own bootstrap (``auc_from_minus1`` is an affine map of ``auc``)."""
FIRST_RETURN_GOAL = "first_return_goal"
"""The score key of the env step of the first greedy return ≥ the file's ``return_goal``."""
DIAGNOSTICS = (
    "first_success", "train_length", "best_eval_return", "value_gap", "greedy_value_gap", "planner_share",
    "model_error_ratio", FIRST_RETURN_GOAL,
)
"""Reported with IQM and CI, but neither better when higher nor compared with the baseline."""

MODEL_FREE = ("ddpg", "cacla", "td3", "sac")
VALUE_GAP_EPISODES = 10
"""Training episodes at the end of a run over which ``value_gap`` is averaged."""
VALUE_GAP_EVALS = 3
"""Greedy evaluations at the end of a run over which ``greedy_value_gap`` is averaged."""
CURVE_POINTS = 200
"""Points of the common env-step grid the learning curves are interpolated to."""


@dataclass
class CellRecord:
    """One finished cell's curve and scores."""

    label: str
    reward: str
    seed: int
    ac: str
    steps: np.ndarray
    """Env step at the end of each training episode."""
    returns: np.ndarray
    """Episodic reward of each training episode."""
    successes: np.ndarray
    """1 where the training episode ended in a grasp, else 0 (NaN where metrics.csv has no column)."""
    scores: dict[str, float]
    start_values: np.ndarray | None = None
    """The critic's value of each training episode's start state (None where metrics.csv has no column)."""
    discounted_returns: np.ndarray | None = None
    """The discounted return each training episode earned (None where metrics.csv has no column)."""


def _column(rows: list[dict[str, str]], key: str) -> np.ndarray | None:
    """A float column of metrics.csv rows (empty cells NaN), or None when the file has no such column."""
    if not rows or key not in rows[0]:
        return None
    return np.asarray([float(row[key]) if row[key] not in ("", None) else math.nan for row in rows])


def _finite_mean(values: np.ndarray) -> float:
    """Mean of the finite entries (NaN when there are none)."""
    finite = values[np.isfinite(values)]
    return float(finite.mean()) if finite.size else math.nan


def _value_gap(start_values: np.ndarray | None, discounted: np.ndarray | None, last: int) -> float:
    """Mean of start value − discounted return over the ``last`` rows that hold both (NaN: unlogged)."""
    if start_values is None or discounted is None:
        return math.nan
    gaps = start_values - discounted
    return _finite_mean(gaps[np.isfinite(gaps)][-last:])


def find_experiment_dir(directory: Path | str) -> Path:
    """``directory`` itself if it holds experiment.yaml, else its only sub-folder that does."""
    root = Path(directory)
    if (root / EXPERIMENT_FILE).is_file():
        return root
    candidates = sorted(p.parent for p in root.glob(f"*/{EXPERIMENT_FILE}")) if root.is_dir() else []
    if len(candidates) == 1:
        return candidates[0]
    if not root.is_dir():
        raise ExperimentError(f"experiment directory not found: {root}")
    if candidates:
        names = ", ".join(str(c) for c in candidates)
        raise ExperimentError(f"{root} holds several experiments; pass one of: {names}")
    raise ExperimentError(f"{root} holds no {EXPERIMENT_FILE} (pass OUT/<experiment>)")


def _second_half_mean(values: np.ndarray | None) -> float:
    """Mean of the finite values of the second half of a per-episode column (NaN: none, or no column)."""
    if values is None:
        return math.nan
    return _finite_mean(values[len(values) // 2 :])


def _planner_share(model_based: np.ndarray | None, model_free: np.ndarray | None) -> float:
    """Share of the logged decisions the model-based system made (NaN: unlogged, or no decision)."""
    if model_based is None or model_free is None:
        return math.nan
    planned = np.nansum(model_based)
    total = planned + np.nansum(model_free)
    return float(planned / total) if total > 0 else math.nan


def _late_error_ratio(model: np.ndarray | None, no_change: np.ndarray | None) -> float:
    """Σ model error / Σ no-change error over the second half's episodes where both are finite (NaN: no
    columns, or no such episode)."""
    if model is None or no_change is None:
        return math.nan
    half = len(model) // 2
    model, no_change = model[half:], no_change[half:]
    both = np.isfinite(model) & np.isfinite(no_change)
    denominator = float(no_change[both].sum())
    return float(model[both].sum()) / denominator if both.any() and denominator > 0 else math.nan


def _first_reaching(steps: list[float], values: np.ndarray | None, goal: float) -> float | None:
    """The step of the first finite value ≥ ``goal`` (None: no such value)."""
    if values is None:
        return None
    return next((step for step, value in zip(steps, values, strict=True) if value >= goal), None)


def read_cell(
    run_dir: Path,
    label: str,
    reward: str,
    seed: int,
    measures: tuple[str, ...] = (),
    return_goal: float | None = None,
) -> CellRecord | None:
    """The scores and curve of a finished cell (None if it is not finished); ``measures``: the file's
    ``episode_measures``, each scored as its second-half mean; ``return_goal``: the file's, which adds
    ``first_return_goal``."""
    if cell_state(run_dir) != "done":
        return None
    summary = read_summary(run_dir) or {}
    with (run_dir / "metrics.csv").open(newline="") as file:
        rows = list(csv.DictReader(file))
    steps = [float(row["global_step"]) for row in rows]
    returns = [float(row["charts/episodic_return"]) for row in rows]
    successes = [float(row.get("charts/success") or "nan") for row in rows]
    success = summary.get("success_rate")
    eval_return = summary.get("eval_return")
    evaluations = _column(rows, "eval/return")
    periodic = [] if evaluations is None else evaluations[np.isfinite(evaluations)].tolist()
    every_eval = periodic + ([] if eval_return is None else [float(eval_return)])
    start_values = _column(rows, "charts/start_value")
    discounted = _column(rows, "charts/discounted_return")
    hits = [step for step, hit in zip(steps, successes, strict=True) if hit == 1.0]
    budget = float(summary.get("steps") or (steps[-1] if steps else math.nan))
    first_success = hits[0] if hits else budget
    goal_scores: dict[str, float] = {}
    if return_goal is not None:
        # A run reaching the goal only at its final evaluation (taken at the end of the budget) and one that
        # never reaches it both count as the budget.
        reached = _first_reaching(steps, evaluations, return_goal)
        goal_scores[FIRST_RETURN_GOAL] = budget if reached is None else reached
    return CellRecord(
        label=label,
        reward=reward,
        seed=seed,
        ac=str(summary.get("ac") or "ddpg"),
        steps=np.asarray(steps),
        returns=np.asarray(returns),
        successes=np.asarray(successes),
        scores={
            "auc": area_under_curve(returns),
            "auc_from_minus1": area_under_curve(returns, baseline=-1.0),
            "final_perf": final_performance(returns),
            # Share of grasps among the last 500 training episodes (Final Perf's window): what exploration
            # finds, where a sparse reward's Final Perf mixes grasps (+1) with topples (−1).
            "train_success": final_performance(successes),
            "success": math.nan if success is None else float(success),
            "eval_return": math.nan if eval_return is None else float(eval_return),
            "first_success": first_success,
            "train_length": final_performance(np.diff(steps, prepend=0.0).tolist()),
            "best_eval_return": max(every_eval) if every_eval else math.nan,
            "value_gap": _value_gap(start_values, discounted, VALUE_GAP_EPISODES),
            "greedy_value_gap": _value_gap(_column(rows, "eval/start_value"),
                                           _column(rows, "eval/discounted_return"), VALUE_GAP_EVALS),
            "planner_share": _planner_share(_column(rows, "dual/mb_decisions"),
                                            _column(rows, "dual/mf_decisions")),
            "model_error_ratio": _late_error_ratio(_column(rows, "dual/model_error"),
                                                   _column(rows, "dual/no_change_error")),
            **{measure: _second_half_mean(_column(rows, measure)) for measure in measures},
            **goal_scores,
        },
        start_values=start_values,
        discounted_returns=discounted,
    )


def collect(directory: Path | str) -> tuple[ExperimentSpec, Path, list[CellRecord], list[str]]:
    """The experiment's spec, folder, finished cells and the keys of the missing ones."""
    root = find_experiment_dir(directory)
    spec = read_experiment(root / EXPERIMENT_FILE)
    records: list[CellRecord] = []
    missing: list[str] = []
    for method in spec.methods:
        for reward in spec.rewards:
            for seed in spec.seeds:
                record = read_cell(
                    cell_dir(root, method.label, reward, seed), method.label, reward, seed,
                    spec.episode_measures, spec.return_goal,
                )
                if record is None:
                    missing.append(f"{method.label}/{reward}/seed-{seed}")
                else:
                    records.append(record)
    return spec, root, records, missing


def _learner_of(method: MethodSpec, records: list[CellRecord]) -> str:
    """The learner (``ac``) a method runs: the file's, else what its finished cells recorded, else ddpg."""
    return method.ac or next((r.ac for r in records if r.label == method.label), "ddpg")


def baselines(spec: ExperimentSpec, records: list[CellRecord]) -> dict[str, str | None]:
    """Each method's model-free baseline label (None for the baselines themselves)."""
    model_free = [m for m in spec.methods if m.algo in MODEL_FREE]
    out: dict[str, str | None] = {}
    for method in spec.methods:
        if spec.baseline is not None:
            out[method.label] = None if method.label == spec.baseline else spec.baseline
            continue
        if method.algo in MODEL_FREE or not model_free:
            out[method.label] = None
            continue
        ac = _learner_of(method, records)
        same_rule = [m for m in model_free if m.algo == ac]
        out[method.label] = (same_rule or model_free)[0].label
    return out


DUAL_SYSTEM = ("im2c", "i2a", "cmc", "la-imagination", "mve")
"""Methods whose intrinsic-motivation peer (RND on the same learner) the report also compares them with."""
PEER_ALGO = "rnd"


def peers(spec: ExperimentSpec, records: list[CellRecord]) -> dict[str, str | None]:
    """Each dual-system method's intrinsic-motivation peer: the file's ``rnd`` method on the same learner
    (``ac``), None where there is none (issue 29: P(dual > RND) beside P(dual > learner alone))."""
    rnd = [m for m in spec.methods if m.algo == PEER_ALGO]
    out: dict[str, str | None] = {}
    for method in spec.methods:
        same = [m for m in rnd if _learner_of(m, records) == _learner_of(method, records)]
        out[method.label] = same[0].label if method.algo in DUAL_SYSTEM and same else None
    return out


def build_report(directory: Path | str, *, reps: int | None = None) -> dict[str, Any]:
    """The report's numbers (see the module docstring) as one JSON-ready dict::

    {"experiment", "directory", "cells", "done", "missing": [keys], "steps", "rewards", "seeds",
     "methods": {label: {reward: {"auc": {"iqm", "ci": [lo, hi], "mean", "std", "n"}, "auc_from_minus1",
                                  "final_perf", "success", "seeds", "baseline",
                                  "prob_improvement": {metric: {"p", "ci"}}}}}}
    """
    return _report_numbers(*collect(directory), reps=reps)


def _report_numbers(
    spec: ExperimentSpec, root: Path, records: list[CellRecord], missing: list[str], *, reps: int | None
) -> dict[str, Any]:
    """:func:`build_report` on already collected cells."""
    from core.experiments.statistics import (
        BOOTSTRAP_REPS,
        affine_summary,
        probability_of_improvement,
        score_summary,
    )

    reps = reps or BOOTSTRAP_REPS
    baseline_of = baselines(spec, records)
    peer_of = peers(spec, records)

    def scores(label: str, reward: str, metric: str) -> list[float]:
        return [r.scores[metric] for r in records if r.label == label and r.reward == reward]

    compared = [m for m in (*BOOTSTRAPPED, *spec.episode_measures) if m not in DIAGNOSTICS]

    def against(label: str, other: str, reward: str) -> dict[str, Any]:
        """P(label > other) on every compared score."""
        return {
            metric: probability_of_improvement(
                scores(label, reward, metric), scores(other, reward, metric), reps=reps
            )
            for metric in compared
        }

    goal_metrics = (FIRST_RETURN_GOAL,) if spec.return_goal is not None else ()
    methods: dict[str, dict[str, Any]] = {}
    for method in spec.methods:
        per_reward: dict[str, Any] = {}
        for reward in spec.rewards:
            entry: dict[str, Any] = {
                metric: score_summary(scores(method.label, reward, metric), reps=reps)
                for metric in (*BOOTSTRAPPED, *spec.episode_measures, *goal_metrics)
            }
            # AuC from −1 is (AuC + 1) / 2 per cell: its statistics follow without a second bootstrap.
            entry["auc_from_minus1"] = affine_summary(entry["auc"], 0.5, 0.5)
            entry["seeds"] = sum(1 for r in records if r.label == method.label and r.reward == reward)
            entry["baseline"], entry["peer"] = baseline_of[method.label], peer_of[method.label]
            if entry["baseline"] is not None:
                entry["prob_improvement"] = against(method.label, entry["baseline"], reward)
                entry["prob_improvement"]["auc_from_minus1"] = entry["prob_improvement"]["auc"]
            if entry["peer"] is not None:
                entry["prob_over_peer"] = against(method.label, entry["peer"], reward)
            per_reward[reward] = entry
        methods[method.label] = per_reward
    total = len(spec.methods) * len(spec.rewards) * len(spec.seeds)
    return {
        "experiment": spec.name,
        "directory": str(root),
        "cells": total,
        "done": total - len(missing),
        "missing": missing,
        "steps": spec.steps,
        "rewards": list(spec.rewards),
        "seeds": list(spec.seeds),
        "env": spec.env,
        "level": spec.level if spec.nico_grasp else None,
        "profile": spec.profile,
        "methods": methods,
    }


def learning_curves(
    spec: ExperimentSpec,
    records: list[CellRecord],
    points: int = CURVE_POINTS,
    series: Literal["returns", "successes"] = "returns",
) -> dict[str, dict[str, dict[str, np.ndarray]]]:
    """Per reward mode and method: ``{"steps", "mean", "std", "n"}`` on a common env-step grid.

    Each cell's episodic rewards (``series="successes"``: its 0/1 grasp outcomes, so the curve is the share
    of training episodes that end in a grasp) are smoothed with the reward mode's sliding window (Fig. 8:
    250 episodes dense, 375 sparse; ``smoothing`` in the file), placed at the env step where each episode
    ended and linearly interpolated to the grid; a seed contributes only between its first and last episode.
    """
    grid = np.linspace(0.0, float(spec.steps), points + 1)[1:]
    curves: dict[str, dict[str, dict[str, np.ndarray]]] = {}
    for reward in spec.rewards:
        window = int(spec.smoothing.get(reward, 250))
        curves[reward] = {}
        for method in spec.methods:
            rows = []
            for record in records:
                if record.label != method.label or record.reward != reward or record.steps.size == 0:
                    continue
                smoothed = smooth(getattr(record, series), window)
                values = np.interp(grid, record.steps, smoothed)
                values[(grid < record.steps[0]) | (grid > record.steps[-1])] = np.nan
                rows.append(values)
            if not rows:
                continue
            stack = np.vstack(rows)
            counts = np.isfinite(stack).sum(axis=0)
            with np.errstate(invalid="ignore"):
                mean = np.where(counts > 0, np.nansum(stack, axis=0) / np.maximum(counts, 1), np.nan)
                deviation = np.sqrt(
                    np.where(
                        counts > 0,
                        np.nansum((stack - mean) ** 2, axis=0) / np.maximum(counts, 1),
                        np.nan,
                    )
                )
            curves[reward][method.label] = {"steps": grid, "mean": mean, "std": deviation, "n": counts}
    return curves


def write_report(directory: Path | str, *, reps: int | None = None) -> dict[str, Any]:
    """Write report.md, learning_curves.png, success_curves.png, scores.png and value_traces.png into the
    experiment folder;
    returns the numbers (:func:`build_report`) with ``"files"`` added."""
    from core.experiments.figures import plot_learning_curves, plot_scores, plot_value_traces

    spec, root, records, missing = collect(directory)  # every metrics.csv read once, for numbers and curves
    report = _report_numbers(spec, root, records, missing, reps=reps)
    files = {
        "report": root / "report.md",
        "learning_curves": root / "learning_curves.png",
        "success_curves": root / "success_curves.png",
        "scores": root / "scores.png",
        "value_traces": root / "value_traces.png",
    }
    plot_learning_curves(spec, learning_curves(spec, records), files["learning_curves"])
    verb = "grasp" if spec.nico_grasp else "succeed"
    plot_learning_curves(spec, learning_curves(spec, records, series="successes"), files["success_curves"],
                         ylabel=f"share of training episodes that {verb} (smoothed)")
    plot_scores(report, [m.label for m in spec.methods], files["scores"])
    plot_value_traces(records, [m.label for m in spec.methods], files["value_traces"])
    atomic_write_text(files["report"], render_markdown(spec, report))
    atomic_write_text(root / "report.json", json.dumps(report, indent=2) + "\n")
    report["files"] = {name: str(path) for name, path in files.items()}
    return report


# -- markdown ------------------------------------------------------------------------------------------


def _number(value: float | None, digits: int = 3) -> str:
    return "–" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def _iqm_cell(summary: dict[str, Any], bold: bool) -> str:
    if summary.get("iqm") is None:
        return "–"
    low, high = summary["ci"]
    text = f"{_number(summary['iqm'])} [{_number(low)}, {_number(high)}]"
    return f"**{text}**" if bold else text


def _mean_cell(summary: dict[str, Any]) -> str:
    if summary.get("mean") is None:
        return "–"
    return f"{_number(summary['mean'])} ± {_number(summary['std'])}"


def _p_cell(entry: dict[str, Any] | None) -> str:
    if not entry or entry.get("p") is None:
        return "–"
    low, high = entry["ci"]
    return f"{entry['p']:.2f} [{low:.2f}, {high:.2f}]"


def _comparison_table(
    spec: ExperimentSpec,
    report: dict[str, Any],
    other: str,
    probabilities: str,
    metrics: list[tuple[str, str]],
    title: str,
    explanation: str,
) -> list[str]:
    """Markdown lines of one P(X > Y) table: each method with an ``other`` (its baseline or its peer) against
    it, ``probabilities`` the entry's key of the P values; no lines when no method has one."""
    rows = [
        (label, reward)
        for label in (m.label for m in spec.methods)
        for reward in spec.rewards
        if report["methods"][label][reward].get(other) is not None
    ]
    if not rows:
        return []
    lines = [
        "", f"## {title}", "", explanation, "",
        f"| method | reward | {other} | " + " | ".join(name for _, name in metrics) + " |",
        "|---|---|---|" + "---|" * len(metrics),
    ]
    for label, reward in rows:
        entry = report["methods"][label][reward]
        lines.append(
            f"| {label} | {reward} | {entry[other]} | "
            + " | ".join(_p_cell(entry[probabilities].get(metric)) for metric, _ in metrics)
            + " |"
        )
    return lines


def render_markdown(spec: ExperimentSpec, report: dict[str, Any]) -> str:
    """report.md: a Table 1-style table, probabilities of improvement, figures and definitions."""
    labels = [m.label for m in spec.methods]
    lines = [f"# Experiment `{spec.name}`", ""]
    if spec.description:
        lines += [spec.description, ""]
    task = f"level `{spec.level}`" if spec.nico_grasp else f"env `{spec.env}`"
    lines += [
        f"{report['done']} of {report['cells']} cells finished · {len(spec.methods)} methods × "
        f"{len(spec.rewards)} reward modes × {len(spec.seeds)} seeds · {spec.steps:,} env steps per cell · "
        f"{task} · profile `{spec.profile}`.",
        "",
    ]
    if report["missing"]:
        lines += [
            f"**Missing cells ({len(report['missing'])})** — not finished, left out of every statistic: "
            + ", ".join(f"`{key}`" for key in report["missing"]),
            "",
        ]
    lines += [
        "## Summary (Table 1 style)",
        "",
        "IQM over seeds with its 95% stratified-bootstrap CI, and mean ± std (the paper's form). "
        "Bold: the highest IQM of the row (none for the episode-length diagnostic).",
        "",
        "| | " + " | ".join(labels) + " |",
        "|---|" + "---|" * len(labels),
    ]
    for reward in spec.rewards:
        lines.append(f"| **{reward.capitalize()} reward** |" + " |" * len(labels))
        for metric, name in METRICS.items():
            cells = [report["methods"][label][reward][metric] for label in labels]
            finite = [c["iqm"] for c in cells if c.get("iqm") is not None]
            best = max(finite) if len(finite) > 1 and metric not in DIAGNOSTICS else None
            lines.append(
                f"| {name} IQM [95% CI] | "
                + " | ".join(_iqm_cell(c, best is not None and c.get("iqm") == best) for c in cells)
                + " |"
            )
            lines.append(f"| {name} mean ± std | " + " | ".join(_mean_cell(c) for c in cells) + " |")
        if spec.return_goal is not None:
            cells = [report["methods"][label][reward][FIRST_RETURN_GOAL] for label in labels]
            name = f"Steps to greedy return ≥ {spec.return_goal:g}"
            lines.append(f"| {name} IQM [95% CI] | " + " | ".join(_iqm_cell(c, False) for c in cells) + " |")
            lines.append(f"| {name} mean ± std | " + " | ".join(_mean_cell(c) for c in cells) + " |")
        for measure in spec.episode_measures:
            cells = [report["methods"][label][reward][measure] for label in labels]
            lines.append(f"| `{measure}` (second half) IQM [95% CI] | "
                         + " | ".join(_iqm_cell(c, False) for c in cells) + " |")
            lines.append(f"| `{measure}` mean ± std | " + " | ".join(_mean_cell(c) for c in cells) + " |")
        seeds = [str(report["methods"][label][reward]["seeds"]) for label in labels]
        lines.append("| seeds | " + " | ".join(seeds) + " |")
    compared_metrics = [(metric, name) for metric, name in METRICS.items() if metric not in DIAGNOSTICS]
    compared_metrics += [(measure, f"`{measure}`") for measure in spec.episode_measures]
    lines += _comparison_table(
        spec, report, "baseline", "prob_improvement", compared_metrics,
        "Probability of improvement over the model-free baseline",
        "P(X > Y): the chance that a run of the method scores higher than a run of its baseline "
        "(Mann-Whitney U / (n·m)), with its 95% bootstrap CI; 0.5 means no difference.",
    )
    lines += _comparison_table(
        spec, report, "peer", "prob_over_peer",
        [(metric, name) for metric, name in compared_metrics if metric != "auc_from_minus1"],
        "Probability of improvement over the intrinsic-motivation peer",
        "P(X > Y) of each dual-system method against RND on the same learner, as above.",
    )
    windows = ", ".join(f"{spec.smoothing.get(r, 250)} episodes ({r})" for r in spec.rewards)
    lines += [
        "",
        "## Learning curves",
        "",
        "![learning curves](learning_curves.png)",
        "",
        f"Episodic reward smoothed with a sliding window of {windows}, interpolated to a common grid of "
        "env steps; line: mean over seeds, band: ± one standard deviation (as Fig. 8/10/11).",
        "",
        "![success curves](success_curves.png)",
        "",
        "The same for the share of training episodes that end in a grasp (training success over time).",
        "",
        "![scores](scores.png)",
        "",
        "## Definitions",
        "",
        "- **AuC** (Section 4.1.2): area under the episodic-reward curve over the area under reward 1, "
        "mean(R) (baseline 0, the paper's text); **AuC (from −1)**: (mean(R) + 1) / 2, the reading that "
        "fits the paper's Table 1 (docs in `core/runs/metrics.py`).",
        "- **Final Perf**: mean episodic reward over the last 500 training episodes.",
        "- **Training success**: share of the last 500 training episodes (with exploration) that ended in a "
        "verified grasp.",
        "- **Greedy success**: success rate of the final greedy evaluation "
        f"({spec.eval_episodes} episodes, fixed evaluation positions); **Greedy return**: its mean "
        "episodic return.",
        "- **Steps to first success** (diagnostic, lower is sooner): env step at the end of the first "
        "training episode that succeeded; a run that never did counts as its whole budget.",
        *(
            [f"- **Steps to greedy return ≥ {spec.return_goal:g}** (diagnostic, lower is sooner; the file's "
             "`return_goal`): env step of the first periodic greedy evaluation whose mean return reached "
             "it; a run where none did counts as its whole budget (as does one where only the final did)."]
            if spec.return_goal is not None else []
        ),
        "- **Best greedy return** (diagnostic): the best greedy evaluation of the run, periodic or final; "
        "beside the final one it tells a run that found the goal and lost it from one that never found it.",
        f"- **Start value − discounted return** (diagnostic): over the last {VALUE_GAP_EPISODES} training "
        "episodes, the critic's value of the start state minus the discounted return the episode earned; "
        "persistently positive is overestimation (empty for runs that do not log it). "
        "Per seed over training: `value_traces.png`.",
        "- **Planner share of training steps** (diagnostic, dual-system methods): the share of the training "
        "steps whose action the arbitration gave the model-based system (empty for the other methods).",
        "- **Model error / no-change error (late half)** (diagnostic, dual-system methods): the world "
        "models' Eq. 8 error summed over the second half's training episodes, over the same sum for "
        "predicting that nothing changes; below 1 the models beat standing still (empty for the other "
        "methods).",
        *(
            [f"- **{', '.join(f'`{m}`' for m in spec.episode_measures)}**: the env's own per-episode "
             "measures (metrics.csv columns), per run the mean over the second half of its training "
             "episodes; P(X > Y) says only which is higher, not which is better."]
            if spec.episode_measures else []
        ),
        "- **IQM**: interquartile mean over seeds (25% trimmed mean); CIs: percentile bootstrap over seeds "
        "(rliable, stratified by task; one task per reward mode), fixed seed.",
        "",
    ]
    return "\n".join(lines)
