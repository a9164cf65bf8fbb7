"""Check: reliability tells learning from noise (Section 2.3.2, Eq. 8-9; ``dual.reliability`` and the
held-out constants `core.dual.readings.HeldOut`: size, every, lag, z, accurate_ratio).

Purpose: the meta-controller should trust a region's model where it is reliable — an accurate model, or one
that is getting better — and distrust a model that gets worse or cannot learn (random outcomes). The check
runs the configured reliability signal on synthetic error streams and reports the share of evaluations at
which each stream's model is trusted. A stream is an error level over the model's age, in units of the
no-change predictor's error, geometric over the ``length`` = 400 evaluated updates (ages 2L .. 2L + 400,
L = `HeldOut.lag`; extrapolated before):

- ``improving``: halves, 0.9 → 0.45 (a real bank model on a learnable stream halved its error over about
  500 updates, docs/dual-system.md);
- ``accurate``: flat and low, 0.25;
- ``rising``: doubles, 0.3 → 0.6 (not in the JSON; asserted by the tests);
- ``unlearnable``: flat at 0.8, the level a model reaches by predicting the mean of random outcomes.

The error of the model at age τ on sample j is ``m(τ) · d_j · |1 + j_s·η_{τ,j} + j_c·ζ_τ|``: ``d_j =
|1 + 0.5 ε_j|`` is the sample's own difficulty (the 50 % per-sample noise of issue #19's measurement),
``η`` a per-(model, sample) jitter and ``ζ`` a per-model common shift (standard normals). The jitters were
measured on real bank models (docs/dual-system.md, "Reliability"): j_s = 0.3, j_c = 0.05 for a model that
learns, 0.1 and 0.02 for one that predicts noise. The no-change predictor's error on sample j is
``|1 + 0.5 ε′_j|``.

- paper, released (LP ≥ 0): the stream of new samples' errors, one per update, feeds `LearningProgress`
  (Eq. 8-9 with the configured σ, W and readings); trusted = LP ≥ 0.
- repaired (held-out): at each evaluation, `HeldOut.size` samples are scored by the current
  model and by the snapshots `HeldOutReliability` would hold (the recent one, L..2L updates back, and the
  oldest of the ring) and judged by `core.dual.reliability.judge`, the very rule the agents use.

`real_model_change` is the second half of the check: a real bank model (the profile's options) on a stream
whose dynamics change mid-way — trusted before the change, distrusted just after it, trusted again once it
has relearnt.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from core.config import DualConfig
from core.dual.learning_progress import LearningProgress
from core.dual.readings import resolve
from core.dual.reliability import SNAPSHOTS, judge
from core.dual.world_models import LocalWorldModels


@dataclass(frozen=True)
class Stream:
    """An error level over the model's age and the jitter of its per-sample errors."""

    start: float
    end: float
    sample_jitter: float
    common_jitter: float

    def level(self, position: np.ndarray | float) -> np.ndarray:
        """m: geometric in the model's age, ``start`` at position 0 and ``end`` at position 1 of the evaluated
        window (extrapolated before it)."""
        return self.start * (self.end / self.start) ** np.asarray(position, dtype=np.float64)


STREAMS = {
    "improving": Stream(0.9, 0.45, 0.3, 0.05),
    "accurate": Stream(0.25, 0.25, 0.3, 0.05),
    "rising": Stream(0.3, 0.6, 0.3, 0.05),
    "unlearnable": Stream(0.8, 0.8, 0.1, 0.02),
}
"""The synthetic streams (module docstring); jitters measured on real models (docs/dual-system.md)."""

DIFFICULTY_NOISE = 0.5
"""Per-sample error noise of the streams (issue #19's 50 %)."""


def _errors(stream: Stream, ages: np.ndarray, first: int, length: int, rng: np.random.Generator,
            difficulty: np.ndarray) -> np.ndarray:
    """Errors ``[len(ages), n]`` of the model at each age on samples of the given difficulties ``[.., n]``;
    the evaluated window is ages ``first .. first + length``."""
    level = stream.level((ages - first) / length)[:, None]
    common = rng.normal(size=(len(ages), 1))
    jitter = rng.normal(size=difficulty.shape)
    return level * difficulty * np.abs(1.0 + stream.sample_jitter * jitter + stream.common_jitter * common)


def trusted_share(dual: DualConfig, stream: Stream, length: int, seed: int) -> float:
    """Share of evaluations (model ages 2L .. 2L + length) at which the configured reliability trusts the
    stream's model."""
    rng = np.random.default_rng(seed)
    read = resolve(dual)
    held_out = read.held_out
    lag = held_out.lag
    first = 2 * lag
    ages = np.arange(first + length)
    evaluated = ages >= first
    if read.reliability.signal == "lp":
        difficulty = np.abs(1.0 + DIFFICULTY_NOISE * rng.normal(size=(ages.size, 1)))
        errors = _errors(stream, ages, first, length, rng, difficulty)[:, 0]
        lp = LearningProgress(window=dual.lp_sigma, history=dual.lp_window,
                              normalise=read.reliability.lp_normalise, warmup=read.reliability.lp_warmup,
                              initial_capacity=1)
        trusted = np.zeros(ages.size, dtype=bool)
        for age in ages:
            lp.record([0], [errors[age]])
            trusted[age] = bool(lp.reliable(0)[0])
        return float(trusted[evaluated].mean())
    now_ages = ages[evaluated]
    taken = now_ages // lag  # snapshots taken at ages L, 2L, ..., kept in a ring of SNAPSHOTS
    recent = (taken - 1) * lag
    oldest = np.maximum(1, taken - SNAPSHOTS + 1) * lag
    n = held_out.size
    difficulty = np.abs(1.0 + DIFFICULTY_NOISE * rng.normal(size=(now_ages.size, n)))
    now = _errors(stream, now_ages, first, length, rng, difficulty)
    befores = [_errors(stream, ages_back, first, length, rng, difficulty) for ages_back in (recent, oldest)]
    no_change = np.abs(1.0 + DIFFICULTY_NOISE * rng.normal(size=(now_ages.size, n)))
    window = dual.lp_sigma  # the newest transitions, each scored by the model of its time
    window_ages = np.maximum(now_ages[:, None] - np.arange(window)[None, :], 0)
    window_difficulty = np.abs(1.0 + DIFFICULTY_NOISE * rng.normal(size=window_ages.shape))
    level = stream.level((window_ages - first) / length)
    jitter = rng.normal(size=window_ages.shape) * stream.sample_jitter
    recent = (level * window_difficulty * np.abs(1.0 + jitter),
              np.abs(1.0 + DIFFICULTY_NOISE * rng.normal(size=window_ages.shape)),
              np.ones(window_ages.shape, dtype=bool))
    verdict = judge(now, befores, no_change, np.ones_like(now, dtype=bool), held_out.z,
                    held_out.accurate_ratio, max(2, n // 2), recent=recent)
    return float(verdict.trusted.mean())


def _changing_stream(steps: int, change_at: int, seed: int, dim: int = 4, actions: int = 2):
    """A latent stream whose dynamics change at ``change_at``: φ′ = φ + 0.2·tanh(A_k φ + B_k a) − 0.05 φ."""
    rng = np.random.default_rng(seed)
    mats = [(rng.normal(size=(dim, dim)) / np.sqrt(dim), rng.normal(size=(dim, actions))) for _ in range(2)]
    phi = rng.normal(size=dim)
    for step in range(steps):
        a_mat, b_mat = mats[int(step >= change_at)]
        action = rng.uniform(-1.0, 1.0, size=actions)
        nxt = phi + 0.2 * np.tanh(a_mat @ phi + b_mat @ action) - 0.05 * phi
        yield phi, action, 0.0, nxt
        phi = nxt


def real_model_change(dual: DualConfig, steps: int = 3000, seed: int = 0) -> dict[str, float]:
    """Share of steps trusted in three stretches of a real (one-region) model's life on a changing stream:
    the quarter before the change, the 5 % just after it, and the last quarter."""
    world = LocalWorldModels(dual, 4, 2, regions=False, generator=torch.Generator().manual_seed(seed),
                             readings=resolve(dual))
    change = steps // 2
    trusted = np.zeros(steps, dtype=bool)
    for step, (phi, action, reward, nxt) in enumerate(_changing_stream(steps, change, seed)):
        world.learn_transition(0, torch.from_numpy(phi).float(), torch.from_numpy(action).float(), reward,
                               torch.from_numpy(nxt).float())
        trusted[step] = world.reliable(0)
    quarter, after = steps // 4, max(1, steps // 20)
    return {
        "before_change": float(trusted[change - quarter:change].mean()),
        "just_after_change": float(trusted[change:change + after].mean()),
        "end": float(trusted[-quarter:].mean()),
    }


def reliability_check(dual: DualConfig, length: int = 400, seeds: int = 3) -> dict[str, float]:
    """The JSON figures: trusted shares of the improving, accurate and unlearnable streams (seed means)."""
    out = {}
    for name in ("improving", "accurate", "unlearnable"):
        shares = [trusted_share(dual, STREAMS[name], length, seed) for seed in range(seeds)]
        out[f"trusted_when_{name}"] = round(float(np.mean(shares)), 3)
    return out
