"""Cells: one (method, reward, seed) of an experiment, each an ordinary run directory.

Layout::

    OUT/<experiment>/
      experiment.yaml                          the normalised experiment file of the last run
      workers.log                              local worker processes' output (warnings, crashes)
      report.md, *.png                         written by ``dualsys experiment report``
      <label>/<reward>/seed-<s>/               a run directory as ``dualsys train`` writes it

A cell is *done* when its ``summary.json`` says the run ended normally (not ``stopped``), *partial* when
``checkpoints/latest.pt`` exists (it resumes from there), *new* otherwise. A folder with episodes but no
checkpoint (a process killed before its first checkpoint) holds nothing to resume: :func:`run_cell`
clears it and starts the cell again.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml

from core.experiments.dispatch import runner_for
from core.experiments.runners import IGNORED_FOR_COMPARISON, EpisodeCallback
from core.experiments.spec import ExperimentError, ExperimentSpec, read_experiment

CellState = Literal["done", "partial", "new"]

EXPERIMENT_FILE = "experiment.yaml"


@dataclass(frozen=True)
class Cell:
    """One run of the grid. Plain data (picklable): it travels to worker processes and Ray tasks."""

    experiment: str
    label: str
    algo: str
    reward: str
    seed: int
    run_dir: Path
    config: Mapping[str, Any]
    """The resolved config (nested dict) the cell trains with."""

    @property
    def key(self) -> str:
        """``label/reward/seed-s``: the cell's name in progress, reports and error messages."""
        return f"{self.label}/{self.reward}/seed-{self.seed}"

    @property
    def steps(self) -> int:
        return int(self.config["run"]["steps"])


def cell_cpu_isa(cell: Cell) -> str:
    """The cell's ``run.cpu_isa`` (``native`` for a config without one): the instruction set its process's
    kernels are pinned to (``core.runs.cpu_isa``)."""
    run = cell.config.get("run") or {}
    return str(run.get("cpu_isa") or "native")


def load_experiment(source: Path | str | Mapping[str, Any]) -> ExperimentSpec:
    """Read and validate an experiment (a YAML path, YAML text or a mapping) and resolve every method's config
    (profile → common overrides → method overrides → the cell's keys), checked as ``dualsys train`` would, so
    a file that loads runs. Raises :class:`ExperimentError`."""
    spec = read_experiment(source)
    for index, method in enumerate(spec.methods):
        runner = runner_for(method.algo, where=f"methods[{index}].algo")
        for reward in spec.rewards:
            runner.resolve(spec, method, reward, spec.seeds[0])
    return spec


def experiment_dir(spec: ExperimentSpec, out: Path | str) -> Path:
    """``OUT/<experiment name>``."""
    return Path(out) / spec.name


def cell_dir(root: Path, label: str, reward: str, seed: int) -> Path:
    return root / label / reward / f"seed-{seed}"


def expand_cells(spec: ExperimentSpec, out_dir: Path | str) -> list[Cell]:
    """Every (method, reward, seed) cell of ``spec`` under ``out_dir``, seed-major within each method and
    reward mode so that a partly run grid has whole seeds of every method early."""
    root = experiment_dir(spec, out_dir)
    cells: list[Cell] = []
    for seed in spec.seeds:
        for method in spec.methods:
            runner = runner_for(method.algo)
            for reward in spec.rewards:
                cells.append(
                    Cell(
                        experiment=spec.name,
                        label=method.label,
                        algo=method.algo,
                        reward=reward,
                        seed=seed,
                        run_dir=cell_dir(root, method.label, reward, seed),
                        config=runner.resolve(spec, method, reward, seed),
                    )
                )
    return cells


def read_summary(run_dir: Path) -> dict[str, Any] | None:
    path = run_dir / "summary.json"
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def cell_state(run_dir: Path) -> CellState:
    summary = read_summary(run_dir)
    if summary is not None and not summary.get("stopped", True):
        return "done"
    if (run_dir / "checkpoints" / "latest.pt").is_file():
        return "partial"
    return "new"


def settings_conflict(cell: Cell) -> str | None:
    """Why ``cell`` cannot continue in its folder (its stored config differs), or None.

    Compares the stored ``config.yaml`` with the cell's resolved config key by key, ignoring keys that do
    not change results (:data:`~core.experiments.runners.IGNORED_FOR_COMPARISON`).
    """
    path = cell.run_dir / "config.yaml"
    if not path.is_file() or cell_state(cell.run_dir) == "new":
        return None
    runner = runner_for(cell.algo)
    try:
        stored = runner.normalise(yaml.safe_load(path.read_text()) or {})
    except (ValueError, yaml.YAMLError) as exc:
        return f"its config.yaml cannot be read ({str(exc).splitlines()[0]})"
    wanted = runner.normalise(cell.config)
    for section in sorted({*stored, *wanted}):
        old, new = stored.get(section, {}), wanted.get(section, {})
        for key in sorted({*old, *new}):
            dotted = f"{section}.{key}"
            if dotted not in IGNORED_FOR_COMPARISON and old.get(key) != new.get(key):
                return f"{dotted} was {old.get(key)!r}, the experiment now gives {new.get(key)!r}"
    return None


def check_cells(cells: list[Cell]) -> None:
    """Refuse to mix settings: raise ExperimentError for the first started cell whose config changed."""
    for cell in cells:
        reason = settings_conflict(cell)
        if reason is not None:
            raise ExperimentError(
                f"cell {cell.key} in {cell.run_dir} was run with other settings: {reason} "
                "(restore the file, use another --out or experiment name, or delete the cell's folder)"
            )


RUN_FILES: tuple[str, ...] = (
    "metrics.csv",
    "summary.json",
    "config.yaml",
    "command.txt",
    "learning_curve.png",
)


def clear_unresumable(run_dir: Path) -> None:
    """Remove what a run killed before its first checkpoint left (episodes that cannot be resumed)."""
    for name in RUN_FILES:
        (run_dir / name).unlink(missing_ok=True)
    checkpoints = run_dir / "checkpoints"
    if checkpoints.is_dir():
        shutil.rmtree(checkpoints)


def run_cell(
    cell: Cell,
    *,
    should_stop: Callable[[], bool] | None = None,
    on_episode: EpisodeCallback | None = None,
    command: str | None = None,
) -> dict[str, Any]:
    """Bring one cell to done: skip it if finished, resume it from ``latest.pt``, or start it afresh.

    Returns the cell's summary (the stored one when it was already done). Safe to call again after any
    interruption: the trainer writes every file atomically and checkpoints by episode and by time.
    """
    state = cell_state(cell.run_dir)
    if state == "done":
        return read_summary(cell.run_dir) or {}
    reason = settings_conflict(cell)
    if reason is not None:
        raise ExperimentError(f"cell {cell.key} was run with other settings: {reason}")
    if state == "new":
        clear_unresumable(cell.run_dir)
    runner = runner_for(cell.algo)
    return runner.train(
        cell.config,
        cell.run_dir,
        resume=state == "partial",
        should_stop=should_stop,
        on_episode=on_episode,
        command=command or f"dualsys experiment run ({cell.experiment}: {cell.key})",
    )
