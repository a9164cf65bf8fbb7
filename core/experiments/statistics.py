"""Aggregate statistics over seeds, the way rliable recommends (Agarwal et al., 2021).

For each (method, reward mode) the per-seed scores form a ``(runs × 1 task)`` matrix; reward modes are
reported separately, as the paper's Table 1 does, so the stratified bootstrap has one stratum (a plain
bootstrap over seeds). Reported beside every point estimate:

* IQM — the interquartile mean (``scipy.stats.trim_mean(x, 0.25)``: drop ⌊n/4⌋ runs at each end, average
  the rest) with its 95% percentile stratified-bootstrap CI (``rliable.library.get_interval_estimates``);
* mean ± std (population std, ``ddof=0``) — what the paper reports;
* probability of improvement P(X > Y) (Mann-Whitney U / (n_x·n_y), ties count ½) with its bootstrap CI.

The bootstrap uses a fixed seed, so a report of the same runs gives the same intervals.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

BOOTSTRAP_REPS = 2000
"""Bootstrap replications per interval (rliable's default is 50000; 2000 keeps a report under seconds
and moves the CI ends by about a hundredth of the score range)."""

BOOTSTRAP_SEED = 0
CONFIDENCE = 0.95


def _finite(scores: Sequence[float] | np.ndarray) -> np.ndarray:
    values = np.asarray(scores, dtype=np.float64).reshape(-1)
    return values[np.isfinite(values)]


def _trimmed_mean(scores: np.ndarray) -> float:
    """``scipy.stats.trim_mean(scores, 0.25, axis=None)`` (rliable's ``aggregate_iqm``), in NumPy: the
    bootstrap calls it thousands of times and scipy's argument handling costs 0.3 ms a call."""
    values = np.sort(scores, axis=None)
    cut = int(0.25 * values.size)
    return float(values[cut : values.size - cut].mean())


def _improvement(scores_x: np.ndarray, scores_y: np.ndarray) -> float:
    """rliable's ``probability_of_improvement`` for one task in NumPy: P(X > Y) + ½ P(X = Y) over all
    pairs of runs, which is the Mann-Whitney U statistic over n_x·n_y."""
    x, y = scores_x.reshape(-1, 1), scores_y.reshape(1, -1)
    return float((x > y).mean() + 0.5 * (x == y).mean())


@contextlib.contextmanager
def _quiet_and_seeded() -> Iterator[None]:
    """Silence arch's warning that ``random_state`` (which rliable passes) will change, and seed NumPy's
    global generator for the duration: rliable's stratified bootstraps draw their resampling indices with
    ``np.random.choice`` and ignore ``random_state``, so without this the CIs changed from one process to
    the next. The caller's global NumPy state is restored afterwards."""
    state = np.random.get_state()
    np.random.seed(BOOTSTRAP_SEED)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=FutureWarning, message=".*random_state.*")
            yield
    finally:
        np.random.set_state(state)


def _generator() -> np.random.RandomState:
    return np.random.RandomState(BOOTSTRAP_SEED)


def iqm(scores: Sequence[float] | np.ndarray) -> float:
    """Interquartile mean (25% trimmed mean) of the finite scores; NaN when there are none."""
    from rliable import metrics

    values = _finite(scores)
    if values.size == 0:
        return math.nan
    return float(metrics.aggregate_iqm(values.reshape(-1, 1)))


def score_summary(scores: Sequence[float] | np.ndarray, reps: int = BOOTSTRAP_REPS) -> dict[str, Any]:
    """``{"iqm", "ci": [lo, hi], "mean", "std", "n"}`` of one method's per-seed scores (NaN dropped)."""
    from rliable import library, metrics

    values = _finite(scores)
    if values.size == 0:
        return {"iqm": None, "ci": [None, None], "mean": None, "std": None, "n": 0}
    with _quiet_and_seeded():
        _, interval = library.get_interval_estimates(
            {"scores": values.reshape(-1, 1)},
            lambda x: np.array([_trimmed_mean(x)]),
            reps=reps,
            confidence_interval_size=CONFIDENCE,
            random_state=_generator(),
        )
    low, high = (float(v) for v in np.asarray(interval["scores"]).reshape(-1)[:2])
    return {
        "iqm": float(metrics.aggregate_iqm(values.reshape(-1, 1))),
        "ci": [low, high],
        "mean": float(values.mean()),
        "std": float(values.std()),
        "n": int(values.size),
    }


def probability_of_improvement(
    scores_x: Sequence[float] | np.ndarray,
    scores_y: Sequence[float] | np.ndarray,
    reps: int = BOOTSTRAP_REPS,
) -> dict[str, Any]:
    """P(X > Y) over runs, with its 95% bootstrap CI: ``{"p", "ci": [lo, hi]}`` (None without scores)."""
    from rliable import library, metrics

    x, y = _finite(scores_x), _finite(scores_y)
    if x.size == 0 or y.size == 0:
        return {"p": None, "ci": [None, None]}
    with _quiet_and_seeded():
        _, interval = library.get_interval_estimates(
            {"pair": (x.reshape(-1, 1), y.reshape(-1, 1))},
            lambda a, b: np.array([_improvement(a, b)]),
            reps=reps,
            confidence_interval_size=CONFIDENCE,
            random_state=_generator(),
        )
    low, high = (float(v) for v in np.asarray(interval["pair"]).reshape(-1)[:2])
    p = metrics.probability_of_improvement(x.reshape(-1, 1), y.reshape(-1, 1))
    return {"p": float(p), "ci": [low, high]}


def affine_summary(summary: dict[str, Any], scale: float, shift: float) -> dict[str, Any]:
    """The summary of ``scale · x + shift`` (scale > 0) from that of x: the IQM, its percentile CI and the
    mean move with the scores, the std scales (no second bootstrap needed)."""

    def moved(value: float | None) -> float | None:
        return None if value is None else scale * value + shift

    return {
        "iqm": moved(summary["iqm"]),
        "ci": [moved(summary["ci"][0]), moved(summary["ci"][1])],
        "mean": moved(summary["mean"]),
        "std": None if summary["std"] is None else scale * summary["std"],
        "n": summary["n"],
    }
