"""Scoring metrics of Section 4.1.2 and the smoothing of Fig. 8.

With R_1 … R_E the episodic rewards (sum of extrinsic rewards of each training episode):

* Area under Curve — the area under the learning curve normalised by the area under reward 1 over the
  same episodes:  AuC = Σ_e (R_e − b) / Σ_e (1 − b) = (mean(R) − b) / (1 − b).
  The paper's text gives the baseline b = 0 (``auc``). Its Table 1 pairs a sparse-reward DDPG with
  AuC 0.028 and Final Perf −0.9, which a b = 0 area cannot produce (negative rewards would make it
  negative); those figures fit an area measured from the lowest per-episode reward, b = −1
  (``auc(returns, baseline=-1)``, reported as ``auc_from_minus1``). Both are written to summary.json.
* Final Performance — mean episodic reward over the last 500 training episodes (all, if fewer).
* Smoothing — a trailing sliding-window mean (Fig. 8: 250 episodes dense, 375 sparse); the first
  ``window − 1`` points average what exists so far, so the curve keeps its length.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

FINAL_PERF_EPISODES = 500
"""Episodes averaged by Final Performance (Section 4.1.2)."""


def area_under_curve(returns: Sequence[float] | np.ndarray, baseline: float = 0.0) -> float:
    """AuC = Σ (R_e − b) / Σ (1 − b); NaN for an empty curve."""
    values = np.asarray(returns, dtype=np.float64)
    if values.size == 0:
        return float("nan")
    if baseline >= 1.0:
        raise ValueError("the AuC baseline must be below the reference reward 1")
    return float((values - baseline).sum() / ((1.0 - baseline) * values.size))


def final_performance(returns: Sequence[float] | np.ndarray, last: int = FINAL_PERF_EPISODES) -> float:
    """Mean episodic reward over the last ``last`` episodes (all if fewer); NaN for an empty curve."""
    values = np.asarray(returns, dtype=np.float64)
    if values.size == 0:
        return float("nan")
    return float(values[-last:].mean())


def smooth(values: Sequence[float] | np.ndarray, window: int) -> np.ndarray:
    """Trailing sliding-window mean of the same length (expanding window for the first points)."""
    data = np.asarray(values, dtype=np.float64)
    if data.size == 0:
        return data
    window = max(1, int(window))
    cumulative = np.concatenate([[0.0], np.cumsum(data)])
    ends = np.arange(1, data.size + 1)
    starts = np.maximum(0, ends - window)
    return (cumulative[ends] - cumulative[starts]) / (ends - starts)
