"""The run directory: resolved config, command, per-episode CSV, summary, checkpoints and learning curve.

Layout::

    RUN_DIR/
      config.yaml            the resolved Config (Config.to_yaml)
      command.txt            the command line that started (or resumed) the run, one line each
      metrics.csv            one row per training episode (record keys as columns)
      summary.json           {"run_dir", "episodes", "steps", "final_perf", "auc", "success_rate", ...}
      learning_curve.png     episodic reward, raw and smoothed (Fig. 8 style), and greedy eval success
      checkpoints/latest.pt  resumable state (agent, counters, RNG, env RNG), torch.load(weights_only=True)
      checkpoints/replay.pt  the replay buffers' filled part (uint8 frames), written with latest.pt
      checkpoints/best.pt    the policy (encoder + actor) of the best greedy evaluation so far

Every file is written atomically: a temporary file in the same folder, then ``os.replace``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import pickle
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from core.config import Config
from core.runs.metrics import smooth

CHECKPOINT_FORMAT = "dualsys-checkpoint/1"


class RunDirectoryError(ValueError):
    """A user-caused run-directory problem (already holds a run, nothing to resume)."""


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same folder and ``os.replace``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as file:
            file.write(data)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temp, path)
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def atomic_torch_save(obj: Any, path: Path) -> None:
    """``torch.save`` through a temporary file and ``os.replace`` (never a half-written checkpoint)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        torch.save(obj, temp)
        os.replace(temp, path)
    except BaseException:
        Path(temp).unlink(missing_ok=True)
        raise


def load_checkpoint(path: Path) -> dict[str, Any]:
    """Load a checkpoint written by this module (weights only: tensors, numbers, strings, containers)."""
    if not path.is_file():
        raise RunDirectoryError(f"checkpoint not found: {path}")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except (pickle.UnpicklingError, RuntimeError, EOFError, ValueError) as exc:
        raise RunDirectoryError(f"{path} is not a dualsys checkpoint ({type(exc).__name__})") from None
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise RunDirectoryError(f"{path} is not a dualsys checkpoint")
    return state


def _csv_value(value: Any) -> Any:
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, float) and math.isnan(value):
        return ""
    return value


class RunDirectory:
    """Paths and writers of one run directory."""

    def __init__(self, root: Path | str) -> None:
        self.root = Path(root)

    # paths
    @property
    def config_path(self) -> Path:
        return self.root / "config.yaml"

    @property
    def command_path(self) -> Path:
        return self.root / "command.txt"

    @property
    def metrics_path(self) -> Path:
        return self.root / "metrics.csv"

    @property
    def summary_path(self) -> Path:
        return self.root / "summary.json"

    @property
    def curve_path(self) -> Path:
        return self.root / "learning_curve.png"

    @property
    def checkpoints(self) -> Path:
        return self.root / "checkpoints"

    @property
    def latest_path(self) -> Path:
        return self.checkpoints / "latest.pt"

    @property
    def best_path(self) -> Path:
        return self.checkpoints / "best.pt"

    @property
    def replay_path(self) -> Path:
        return self.checkpoints / "replay.pt"

    def holds_run(self) -> bool:
        """True when a run was already started here (metrics or a checkpoint exist)."""
        return self.metrics_path.exists() or self.latest_path.exists()

    # writers
    def create(self) -> None:
        self.checkpoints.mkdir(parents=True, exist_ok=True)

    def write_config(self, config: Config) -> None:
        atomic_write_text(self.config_path, config.to_yaml())

    def append_command(self, command: str) -> None:
        previous = self.command_path.read_text() if self.command_path.exists() else ""
        atomic_write_text(self.command_path, previous + command.rstrip("\n") + "\n")

    def write_summary(self, summary: Mapping[str, Any]) -> None:
        clean = {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in summary.items()
        }
        atomic_write_text(self.summary_path, json.dumps(clean, indent=2) + "\n")

    def write_learning_curve(
        self,
        returns: list[float],
        evals: list[tuple[int, float]],
        window: int,
        title: str,
        diagnostics: Mapping[str, list[float]] | None = None,
    ) -> None:
        """PNG of episodic reward (raw, and smoothed with ``window``) and greedy eval success rate; with
        dual-system ``diagnostics`` (the ``dual/…`` columns) a second panel (core.dual.diagnostics_panel)."""
        import matplotlib

        matplotlib.use("Agg")
        from matplotlib import pyplot as plt

        from core.dual.diagnostics_panel import draw_dual_panel, has_dual_diagnostics

        second = diagnostics is not None and has_dual_diagnostics(diagnostics)
        if second:
            figure, (axis, panel) = plt.subplots(2, 1, figsize=(7, 7), dpi=100, sharex=True)
            draw_dual_panel(panel, diagnostics, window)
        else:
            figure, axis = plt.subplots(figsize=(7, 4), dpi=100)
        episodes = list(range(1, len(returns) + 1))
        if returns:
            axis.plot(episodes, returns, color="tab:blue", alpha=0.2, linewidth=0.6, label="episodic reward")
            axis.plot(
                episodes,
                smooth(returns, window),
                color="tab:blue",
                linewidth=1.8,
                label=f"smoothed ({window} episodes)",
            )
        axis.set_xlabel("episode")
        axis.set_ylabel("episodic reward")
        axis.set_title(title)
        axis.grid(alpha=0.3)
        if evals:
            success_axis = axis.twinx()
            success_axis.plot(
                [e for e, _ in evals],
                [s for _, s in evals],
                "o-",
                color="tab:green",
                markersize=3,
                label="greedy success rate",
            )
            success_axis.set_ylim(-0.02, 1.02)
            success_axis.set_ylabel("greedy success rate")
            success_axis.legend(loc="lower right", fontsize=8)
        axis.legend(loc="upper left", fontsize=8)
        figure.tight_layout()
        buffer = io.BytesIO()
        figure.savefig(buffer, format="png")
        plt.close(figure)
        atomic_write_bytes(self.curve_path, buffer.getvalue())


class MetricsCSV:
    """metrics.csv, one row per training episode; new keys extend the header (the file is rewritten)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.columns: list[str] = []
        self.rows: list[dict[str, Any]] = []
        if path.exists():
            with path.open(newline="") as file:
                reader = csv.DictReader(file)
                self.columns = list(reader.fieldnames or [])
                self.rows = [dict(row) for row in reader]

    def truncate_after(self, episode: int) -> None:
        """Drop rows of episodes after ``episode`` (written after the checkpoint a resume starts from)."""
        kept = [row for row in self.rows if int(float(row.get("episode", 0) or 0)) <= episode]
        if len(kept) != len(self.rows):
            self.rows = kept
            self._rewrite()

    def column(self, key: str) -> list[float]:
        return [float(row[key]) if row.get(key, "") not in ("", None) else math.nan for row in self.rows]

    def append(self, record: Mapping[str, Any]) -> None:
        row = {key: _csv_value(value) for key, value in record.items()}
        new_keys = [key for key in row if key not in self.columns]
        self.rows.append(row)
        if new_keys or not self.path.exists():
            self.columns.extend(new_keys)
            self._rewrite()
            return
        with self.path.open("a", newline="") as file:
            csv.DictWriter(file, fieldnames=self.columns).writerow(row)

    def _rewrite(self) -> None:
        text = io.StringIO()
        writer = csv.DictWriter(text, fieldnames=self.columns)
        writer.writeheader()
        writer.writerows(self.rows)
        atomic_write_text(self.path, text.getvalue())
