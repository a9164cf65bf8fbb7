"""Benchmark: wall-clock time of the smoke experiment (experiments/smoke.yaml) on 1 and on 2 local workers.

Both runs happen in the same call, each into a fresh temporary folder, so they see the same machine
load. ``speedup = workers_1_s / workers_2_s`` (goal ≥ 1.7 on 2 idle cores). Each time covers everything
``dualsys experiment run`` does: spawning the workers (imports included), training every cell, writing the
run directories.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from core.experiments import load_experiment, run_experiment

SMOKE = Path(__file__).resolve().parents[1] / "experiments" / "smoke.yaml"


def _timed_run(file: Path, workers: int) -> float:
    spec = load_experiment(file)
    with tempfile.TemporaryDirectory(prefix="dualsys-bench-experiment-") as out:
        start = time.perf_counter()
        result = run_experiment(spec, out, workers=workers)
        elapsed = time.perf_counter() - start
    if not result.complete:
        raise RuntimeError(f"the benchmark grid did not finish: {result.to_dict()}")
    return elapsed


def measure(file: Path | str = SMOKE) -> dict[str, float | int | str]:
    """``{"workers_1_s", "workers_2_s", "speedup", "cells", "experiment"}``."""
    path = Path(file)
    spec = load_experiment(path)
    cells = len(spec.methods) * len(spec.rewards) * len(spec.seeds)
    one = _timed_run(path, workers=1)
    two = _timed_run(path, workers=2)
    return {
        "experiment": path.stem,
        "cells": cells,
        "workers_1_s": round(one, 2),
        "workers_2_s": round(two, 2),
        "speedup": round(one / two, 2),
    }
