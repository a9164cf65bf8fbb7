"""Factory: a run directory in the layout `core.runs.trainer.train` writes, with real (tiny) files.

Used where a test needs a registrable run directory without spending seconds on a training run;
the end-to-end service tests register directories made by the real trainer instead.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import torch
import yaml


def make_run_dir(
    folder: Path,
    *,
    seed: int = 0,
    episodes: int = 3,
    success_rate: float = 0.5,
    with_checkpoint: bool = True,
) -> Path:
    """Write config.yaml, summary.json, metrics.csv and (optionally) checkpoints/{latest,best}.pt."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.yaml").write_text(
        yaml.safe_dump({"seed": seed, "algo": "i2a", "reward": "sparse", "episodes": episodes})
    )
    (folder / "summary.json").write_text(
        json.dumps({"episodes": episodes, "final_success_rate": success_rate, "auc": 0.25})
    )
    rows = ["episode,global_step,charts/episodic_return,charts/success"]
    rows += [f"{e},{e * 10},{-1.0 + e / 10},{int(e % 2 == 0)}" for e in range(1, episodes + 1)]
    (folder / "metrics.csv").write_text("\n".join(rows) + "\n")
    if with_checkpoint:
        (folder / "checkpoints").mkdir(exist_ok=True)
        generator = torch.Generator().manual_seed(seed)
        state = {"actor": {"weight": torch.randn(2, 3, generator=generator)}, "episode": episodes}
        torch.save(state, folder / "checkpoints" / "latest.pt")
        torch.save(state, folder / "checkpoints" / "best.pt")
    return folder


WALL_CLOCK_PREFIXES = ("time/", "charts/sps")
"""metrics.csv columns that measure the machine, not the run: left out where two runs are compared."""


def metrics_rows(run_dir: Path, *, without_wall_clock: bool = False) -> list[dict[str, str]]:
    """A run's metrics.csv as rows (strings, as written); ``without_wall_clock`` drops the timing columns."""
    with (Path(run_dir) / "metrics.csv").open(newline="") as file:
        rows = list(csv.DictReader(file))
    if without_wall_clock:
        rows = [{k: v for k, v in row.items() if not k.startswith(WALL_CLOCK_PREFIXES)} for row in rows]
    return rows
