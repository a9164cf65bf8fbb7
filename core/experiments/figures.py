"""Figures of an experiment report (matplotlib, Agg backend, written atomically).

* ``learning_curves.png`` — one panel per reward mode, each method's mean smoothed episodic reward over
  env steps with a ± one-standard-deviation band (the style of the paper's Fig. 8, 10 and 11);
  ``success_curves.png`` the same for the share of training episodes that end in a grasp.
* ``scores.png`` — per reward mode (rows) and score (columns), each method's IQM with its 95% CI
  (the interval plot rliable recommends).
* ``value_traces.png`` — one panel per method, every seed's critic value of the start state (solid) beside
  the discounted return the episode earned (dashed, same colour) over env steps: overestimation in sight.
* the noisy TV's late half (`plot_noisy_tv`, issue 50): each seed's share of late steps at the noise against
  its late coverage of the rest, one colour per method, the IQMs crossed — where a method sits between
  "drawn to the noise" and "covers the rest".
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from core.runs.run_dir import atomic_write_bytes

if TYPE_CHECKING:
    from core.experiments.spec import ExperimentSpec


class ValueTrace(Protocol):
    """What :func:`plot_value_traces` reads of a finished cell (``core.experiments.report.CellRecord``)."""

    label: str
    reward: str
    seed: int
    steps: np.ndarray
    start_values: np.ndarray | None
    discounted_returns: np.ndarray | None


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    return plt


def _save(figure: Any, path: Path) -> None:
    plt = _pyplot()
    buffer = io.BytesIO()
    figure.tight_layout()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    atomic_write_bytes(path, buffer.getvalue())


def _colours(labels: list[str]) -> dict[str, Any]:
    plt = _pyplot()
    cycle = plt.get_cmap("tab10")
    return {label: cycle(index % 10) for index, label in enumerate(labels)}


def plot_learning_curves(
    spec: ExperimentSpec,
    curves: dict[str, dict[str, dict[str, np.ndarray]]],
    path: Path,
    ylabel: str = "episodic reward (smoothed)",
) -> None:
    """Mean ± std learning curves, one panel per reward mode (``report.learning_curves`` output)."""
    plt = _pyplot()
    labels = [m.label for m in spec.methods]
    colours = _colours(labels)
    panels = len(spec.rewards)
    figure, axes = plt.subplots(1, panels, figsize=(6.0 * panels, 4.2), dpi=100, squeeze=False)
    for index, (axis, reward) in enumerate(zip(axes[0], spec.rewards, strict=True)):
        for label in labels:
            curve = curves.get(reward, {}).get(label)
            if curve is None:
                continue
            seeds = int(np.max(curve["n"])) if curve["n"].size else 0
            axis.plot(
                curve["steps"],
                curve["mean"],
                color=colours[label],
                linewidth=1.8,
                label=f"{label} ({seeds} seeds)",
            )
            axis.fill_between(
                curve["steps"],
                curve["mean"] - curve["std"],
                curve["mean"] + curve["std"],
                color=colours[label],
                alpha=0.2,
                linewidth=0,
            )
        axis.set_title(f"({chr(ord('a') + index)}) {reward} reward")
        axis.set_xlabel("environment steps")
        axis.set_ylabel(ylabel)
        axis.set_xlim(0, spec.steps)
        axis.grid(alpha=0.3)
        if axis.get_legend_handles_labels()[0]:
            axis.legend(fontsize=8, loc="upper right")
    figure.suptitle(f"{spec.name}: mean over seeds, band ± 1 std", fontsize=11)
    _save(figure, path)


def plot_scores(report: dict[str, Any], labels: list[str], path: Path) -> None:
    """IQM with 95% CI per method: rows are reward modes, columns AuC, Final Perf and greedy success."""
    plt = _pyplot()
    metrics = {"auc": "AuC", "final_perf": "Final Perf", "success": "Greedy success"}
    rewards = list(report["rewards"])
    colours = _colours(labels)
    figure, axes = plt.subplots(
        len(rewards),
        len(metrics),
        figsize=(3.6 * len(metrics), 0.45 * len(labels) * len(rewards) + 1.6),
        dpi=100,
        squeeze=False,
    )
    for row, reward in enumerate(rewards):
        for column, (metric, name) in enumerate(metrics.items()):
            axis = axes[row][column]
            for position, label in enumerate(labels):
                summary = report["methods"][label][reward][metric]
                if summary.get("iqm") is None:
                    continue
                low, high = summary["ci"]
                axis.plot([low, high], [position, position], color=colours[label], linewidth=6, alpha=0.5)
                axis.plot([summary["iqm"]], [position], "|", color="black", markersize=14)
            axis.set_yticks(range(len(labels)))
            axis.set_yticklabels(labels if column == 0 else [""] * len(labels))
            axis.set_ylim(-0.7, len(labels) - 0.3)
            axis.invert_yaxis()
            axis.grid(axis="x", alpha=0.3)
            axis.set_title(f"{name} · {reward}", fontsize=10)
    figure.suptitle(f"{report['experiment']}: IQM and 95% bootstrap CI over seeds", fontsize=11)
    _save(figure, path)


def plot_value_traces(records: Sequence[ValueTrace], labels: list[str], path: Path) -> None:
    """Per method (panels), per seed (colours): start-state value (solid) and discounted return (dashed) of
    each training episode over env steps; methods that log neither get a panel saying so."""
    plt = _pyplot()
    columns = min(4, max(1, len(labels)))
    rows = -(-len(labels) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.2 * rows), dpi=100, squeeze=False)
    cycle = plt.get_cmap("tab10")
    for index, label in enumerate(labels):
        axis = axes[index // columns][index % columns]
        logged = [r for r in records if r.label == label and r.start_values is not None]
        for order, record in enumerate(sorted(logged, key=lambda r: (r.reward, r.seed))):
            style = {"color": cycle(order % 10), "linewidth": 1.0}
            axis.plot(record.steps, record.start_values, label=f"seed {record.seed}", **style)
            if record.discounted_returns is not None:
                axis.plot(record.steps, record.discounted_returns, linestyle="--", **style)
        if not logged:
            axis.text(0.5, 0.5, "no start values logged", ha="center", va="center", transform=axis.transAxes)
            axis.set_xticks([])
            axis.set_yticks([])
        else:
            axis.legend(fontsize=7, loc="best")
        axis.set_title(label, fontsize=10)
        axis.set_xlabel("env steps")
        axis.grid(alpha=0.3)
    for index in range(len(labels), rows * columns):
        axes[index // columns][index % columns].axis("off")
    figure.suptitle("critic's value of the start state (solid) and discounted return earned (dashed)",
                    fontsize=11)
    _save(figure, path)


def plot_noisy_tv(table: dict[str, Any], path: Path, title: str = "") -> None:
    """Each seed's (late noise share, late coverage of the rest) of `core.experiments.noisy_tv_table`'s
    ``method_table``, a colour per method, with a cross at the method's IQMs of the two."""
    plt = _pyplot()
    labels = list(table)
    colours = _colours(labels)
    figure, axis = plt.subplots(figsize=(7.2, 4.8), dpi=100)
    for label in labels:
        row = table[label]
        axis.scatter(row["noise_share"], row["coverage_rest"], color=colours[label], alpha=0.55, s=28,
                     label=f"{label} ({len(row['seeds'])} seeds)")
        axis.plot([row["noise_share_iqm"]["iqm"]], [row["coverage_rest_iqm"]["iqm"]], marker="X",
                  color=colours[label], markersize=12, markeredgecolor="black")
    axis.set_xlabel("share of late steps at the noise (lower is better)")
    axis.set_ylabel("late coverage of the cells outside the noise")
    axis.set_xlim(-0.03, 1.0)
    axis.set_ylim(0.0, 1.02)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8, loc="upper right")
    axis.set_title(title or "noisy TV, late half of training: dots are seeds, crosses IQMs", fontsize=10)
    _save(figure, path)
