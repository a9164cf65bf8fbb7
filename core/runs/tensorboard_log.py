"""TensorBoard event files of a run (``run.tensorboard``), written beside metrics.csv with the same names.

Each episode record becomes one scalar per numeric column of metrics.csv (``charts/episodic_return``,
``eval/success_rate``, ``losses/critic``, ``dual/...``) at step ``global_step``, the env-step axis; the two
counters themselves (``episode``, ``global_step``) and values that are not finite (NaN: "no evaluation this
episode") are left out. The event files go to the run directory itself, so ``tensorboard --logdir
dualsys-runs`` shows each run under its folder's name and ``--logdir <experiment folder>`` each cell as
``label/reward/seed-s``.

A resumed run writes a new event file whose first event purges everything from the step after its
checkpoint on (``purge_step``), so the episodes the lost session wrote past the checkpoint, which the run
repeats, are shown once, as metrics.csv keeps them once. The writer is torch's ``SummaryWriter``, which
needs the ``tensorboard`` package (``pip install 'dualsys[tensorboard]'``).
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from typing import Any

from core.config import ConfigError

COUNTERS = ("episode", "global_step")
"""metrics.csv columns that are the axes, not scalars."""
FLUSH_S = 5
"""Seconds between flushes of the event file (it is also flushed when the run ends)."""


def require_tensorboard() -> None:
    """ConfigError, before the run starts, when ``run.tensorboard`` is set and the package is missing."""
    if importlib.util.find_spec("tensorboard") is None:
        raise ConfigError("run.tensorboard needs the tensorboard package: pip install 'dualsys[tensorboard]'")


class TensorBoardLog:
    """One run's event file writer; ``add`` takes episode records as metrics.csv gets them."""

    def __init__(self, folder: Path, *, purge_from_step: int | None = None) -> None:
        from torch.utils.tensorboard import SummaryWriter

        self.writer = SummaryWriter(log_dir=str(folder), purge_step=purge_from_step, flush_secs=FLUSH_S)

    def add(self, record: dict[str, Any]) -> None:
        step = int(record["global_step"])
        for key, value in record.items():
            if key in COUNTERS or isinstance(value, bool) or not isinstance(value, int | float):
                continue
            if math.isfinite(value):
                self.writer.add_scalar(key, float(value), global_step=step)

    def close(self) -> None:
        self.writer.close()
