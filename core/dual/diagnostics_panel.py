"""The learning-curve picture's second panel: the dual-system diagnostics per episode (the data of Fig. 9).

The ``dual/…`` columns of metrics.csv have different units (decisions per episode, a horizon in steps, a
node count, an error, a reward), so each series is smoothed with the curve's window and divided by its
largest absolute value; the legend gives that maximum, so every line reads as "fraction of its peak"
(Fig. 9(a) normalises the model error to [0, 1] the same way). NaN entries (e.g. the horizon of an
episode without model-based decisions) are skipped by the smoothing.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

PANEL_KEYS: tuple[tuple[str, str], ...] = (
    ("dual/model_error", "model error"),
    ("dual/mb_decisions", "model-based decisions"),
    ("dual/mf_decisions", "model-free decisions"),
    ("dual/horizon", "planning horizon"),
    ("dual/itm_nodes", "ITM nodes"),
    ("dual/imagined", "imagined transitions"),
    ("dual/intrinsic_reward", "intrinsic reward"),
    ("dual/region_rint_mean", "r_int over regions: mean"),
    ("dual/region_rint_std", "r_int over regions: spread"),
)
"""Which columns the panel draws, in order, with their legend names."""


def smooth_skipping_nan(values: Sequence[float], window: int) -> np.ndarray:
    """Trailing mean over the last ``window`` finite values at each episode (NaN before the first one)."""
    data = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(data)
    sums = np.concatenate([[0.0], np.cumsum(np.where(finite, data, 0.0))])
    counts = np.concatenate([[0], np.cumsum(finite)])
    ends = np.arange(1, data.size + 1)
    starts = np.maximum(0, ends - max(1, int(window)))
    n = counts[ends] - counts[starts]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, (sums[ends] - sums[starts]) / np.maximum(n, 1), np.nan)


def has_dual_diagnostics(columns: Mapping[str, Sequence[float]]) -> bool:
    return any(np.isfinite(np.asarray(columns.get(key, []), dtype=np.float64)).any() for key, _ in PANEL_KEYS)


def draw_dual_panel(axis: Any, columns: Mapping[str, Sequence[float]], window: int) -> None:
    """Draw each present ``dual/…`` series, smoothed and normalised by its peak, on a matplotlib axis."""
    for key, label in PANEL_KEYS:
        values = columns.get(key)
        if values is None or len(values) == 0:
            continue
        curve = smooth_skipping_nan(values, window)
        peak = np.nanmax(np.abs(curve)) if np.isfinite(curve).any() else np.nan
        if not np.isfinite(peak):
            continue
        scaled = curve / peak if peak > 0 else curve
        axis.plot(np.arange(1, len(curve) + 1), scaled, linewidth=1.4, label=f"{label} (max {peak:.3g})")
    axis.set_xlabel("episode")
    axis.set_ylabel("fraction of peak")
    axis.set_title(f"dual-system diagnostics per episode (smoothed, {window} episodes)", fontsize=9)
    axis.grid(alpha=0.3)
    axis.legend(loc="upper left", fontsize=7, ncol=2)
