"""NoisyTV: ThreeRegions with a fixed start away from the noise, and its exploration measured over training.

Issue 50, item 4. Study 3's noisy TV (``dualsys/ThreeRegions-v0``, `core.envs.three_regions`) starts each
episode uniformly over the square and scores one episode's cells, which cannot show exploration (a random
walk covers 0.071–0.073 of the rest, every method 0.04–0.08). This variant keeps the dynamics, the spaces,
the 200-step episodes and the per-episode measures of ThreeRegions and changes two things:

- **The start.** Every episode starts at ``start_position`` (−0.9, 0.0), in the trivial region, 1.23 from the
  noise (x ≥ 1/3): at least 25 steps at speed 0.05 straight right. ``start_jitter`` > 0 adds a uniform offset
  in [−jitter, jitter]² from the env's seeded generator (0 by default: the same start every episode);
  ``start="uniform"`` restores ThreeRegions' uniform start.
- **What an episode records.** Besides ``env/noise_share`` and ``env/coverage_rest`` (as ThreeRegions), the
  last step's ``info["episode_diagnostics"]`` holds the episode's visited cells outside the noise: the
  ``COVERAGE_CELLS`` × ``COVERAGE_CELLS`` grid (15 × 15 over the square, cell side 2/15) has ``REST_COLUMNS``
  (10) columns left of x = 1/3 — exactly the trivial and learnable regions, 150 cells. Cell ``(i, j)`` (i
  the column by x, j the row by y) is bit ``k = 15 i + j`` of a 150-bit mask, written as three integers of
  ``MASK_BITS`` (50) bits, exact in a float64: ``env/rest_cells_0`` (bits 0–49), ``env/rest_cells_1``
  (50–99), ``env/rest_cells_2`` (100–149). The trainer writes them into metrics.csv like every env
  diagnostic (`core.runs.bookkeeping.env_diagnostics`), so any window of episodes can be unioned later.

**The measure** (`late_half_measures`, `run_measures`, and ``python -m core.envs.noisy_tv DIR...``):

- the late half of training is the training episodes that *start* in the second half of the env-step
  budget — first step after ``budget / 2``, i.e. ``global_step − charts/length ≥ budget / 2`` (``budget``:
  the run's ``run.steps``, or its last ``global_step`` where the run had no step budget). With 200-step
  episodes and 20k steps: episodes 51–100, env steps 10001–20000. Evaluation episodes never count (they
  run on a separate env and write no episode row);
- ``late/coverage_rest``: the share of the 150 cells outside the noise visited by any of those episodes
  (the union of their masks; positions after each step, and each episode's start cell — with the fixed
  start always cell (0, 7), 1 of the 150);
- ``late/noise_share``: the share of those episodes' steps that ended in the noise region
  (Σ ``env/noise_share`` · length / Σ length).

Registered as ``dualsys/NoisyTV-v0`` (``core/envs/__init__.py``).
"""

from __future__ import annotations

import csv
import json
import math
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from core.envs.three_regions import COVERAGE_CELLS, REST_COLUMNS, ThreeRegionsEnv

START_POSITION = (-0.9, 0.0)
"""The fixed start: in the trivial region, 0.1 from the left wall, 1.23 from the noise."""

MASK_BITS = 50
"""Bits per mask column (< 53, so each is an exact float64 in metrics.csv)."""

REST_CELLS = REST_COLUMNS * COVERAGE_CELLS
"""Cells outside the noise region: 150."""

MASK_COLUMNS: tuple[str, ...] = tuple(f"env/rest_cells_{k}" for k in range(-(-REST_CELLS // MASK_BITS)))
"""The metrics.csv columns of an episode's visited-cell mask (bit ``15 i + j`` = cell (i, j))."""


def encode_cells(visited: np.ndarray) -> dict[str, float]:
    """The mask columns of a ``COVERAGE_CELLS`` × ``COVERAGE_CELLS`` boolean grid's cells outside the noise
    (indexed ``[i, j]``, i by x)."""
    bits = np.asarray(visited, dtype=bool)[:REST_COLUMNS].reshape(-1)  # bit 15 i + j
    mask = sum(1 << int(k) for k in np.flatnonzero(bits))
    return {column: float((mask >> (MASK_BITS * k)) & ((1 << MASK_BITS) - 1))
            for k, column in enumerate(MASK_COLUMNS)}


def decode_cells(row: Mapping[str, Any]) -> int:
    """The 150-bit mask of a metrics.csv row (or a diagnostics dict); 0 where a column is missing or empty."""
    mask = 0
    for k, column in enumerate(MASK_COLUMNS):
        value = row.get(column, "")
        if value not in ("", None) and not (isinstance(value, float) and math.isnan(value)):
            mask |= int(float(value)) << (MASK_BITS * k)
    return mask


class NoisyTVEnv(ThreeRegionsEnv):
    """See the module docstring."""

    def __init__(
        self,
        max_steps: int = 200,
        speed: float = 0.05,
        frequency: float = 2.0,
        start: str = "fixed",
        start_position: Sequence[float] = START_POSITION,
        start_jitter: float = 0.0,
    ) -> None:
        super().__init__(max_steps=max_steps, speed=speed, frequency=frequency)
        if start not in ("fixed", "uniform"):
            raise ValueError(f"start must be 'fixed' or 'uniform', not {start!r}")
        position = np.asarray(start_position, dtype=np.float64).reshape(-1)
        if position.shape != (2,) or np.any(np.abs(position) > 1.0):
            raise ValueError(f"start_position must be two numbers in [-1, 1], not {start_position!r}")
        if not start_jitter >= 0.0:
            raise ValueError(f"start_jitter must be >= 0, not {start_jitter!r}")
        self.start = start
        self.start_position = position
        self.start_jitter = float(start_jitter)

    def _start_position(self) -> np.ndarray:
        if self.start == "uniform":
            return super()._start_position()
        if self.start_jitter == 0.0:
            return self.start_position.copy()
        jitter = self.np_random.uniform(-self.start_jitter, self.start_jitter, size=2)
        return np.clip(self.start_position + jitter, -1.0, 1.0)

    def episode_diagnostics(self) -> dict[str, float]:
        """ThreeRegions' two measures and the episode's visited-cell mask columns (module docstring)."""
        return {**super().episode_diagnostics(), **encode_cells(self._visited)}


# -- the measure over training -------------------------------------------------------------------------


def late_half_measures(rows: Iterable[Mapping[str, Any]], budget: float | None = None) -> dict[str, float]:
    """``late/noise_share`` and ``late/coverage_rest`` of the training episodes that start in the second
    half of ``budget`` env steps (default: the last row's ``global_step``), with ``late/episodes`` and
    ``late/steps`` they cover; the rows are metrics.csv's (or records with the same keys)."""
    rows = list(rows)
    if budget is None:
        budget = max((float(row["global_step"]) for row in rows), default=0.0)
    union, steps, noise_steps, episodes = 0, 0.0, 0.0, 0
    for row in rows:
        length = float(row["charts/length"])
        if float(row["global_step"]) - length < budget / 2:
            continue
        union |= decode_cells(row)
        steps += length
        noise_steps += float(row["env/noise_share"]) * length
        episodes += 1
    return {
        "late/noise_share": noise_steps / steps if steps else math.nan,
        "late/coverage_rest": union.bit_count() / REST_CELLS if episodes else math.nan,
        "late/episodes": float(episodes),
        "late/steps": steps,
    }


def run_measures(run_dir: Path | str) -> dict[str, float]:
    """`late_half_measures` of a run directory (live or archived: metrics.csv, and config.yaml's
    ``run.steps`` as the budget where it has one)."""
    run_dir = Path(run_dir)
    budget = None
    config_path = run_dir / "config.yaml"
    if config_path.exists():
        import yaml

        steps = ((yaml.safe_load(config_path.read_text()) or {}).get("run") or {}).get("steps")
        budget = float(steps) if steps else None
    with (run_dir / "metrics.csv").open(newline="") as file:
        return late_half_measures(csv.DictReader(file), budget)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m core.envs.noisy_tv DIR...``: one JSON line per run directory found under each DIR (a
    run, a cell folder or a whole experiment), with its late-half measures (per method, with IQMs and P
    against baselines: ``python -m core.experiments.noisy_tv_table``)."""
    dirs = list(sys.argv[1:] if argv is None else argv)
    if not dirs:
        print("usage: python -m core.envs.noisy_tv DIR...  (runs, cells or experiment folders)",
              file=sys.stderr)
        return 2
    for top in map(Path, dirs):
        for metrics in sorted(top.rglob("metrics.csv")):
            print(json.dumps({"run": str(metrics.parent), **run_measures(metrics.parent)}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
