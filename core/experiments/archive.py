"""Archives: an experiment's numbers without its checkpoints, small enough to keep in git.

A grid's folder holds checkpoints and replay-free but still large run directories; what its report reads is
far smaller: per done cell ``metrics.csv`` and ``summary.json`` (with ``config.yaml``, ``command.txt`` and an
SB3 peer's ``sb3_hyperparams.json`` to say how it ran). :func:`archive_experiment` copies those into
``DEST/<experiment>/`` in the grid's own layout, so ``dualsys experiment report DEST/<experiment>`` works on
it, and a grid run in pieces (seeds on different days or machines) merges into one archive: the stored
experiment.yaml becomes the union of the methods and seeds archived so far. Pieces that disagree on anything
else (budget, task, profile, common overrides) are refused rather than mixed.

:func:`restore_archive` is the way back: it copies an archive's done cells into an output folder where those
cells have not started, so that ``dualsys experiment run --from-archive`` on a machine that kept nothing but
the repository skips them and runs only the rest of the grid.
"""

from __future__ import annotations

import dataclasses
import itertools
import shutil
from dataclasses import dataclass
from pathlib import Path

from core.experiments.cells import (
    EXPERIMENT_FILE,
    cell_dir,
    cell_state,
    clear_unresumable,
    expand_cells,
    settings_conflict,
)
from core.experiments.report import find_experiment_dir
from core.experiments.spec import ExperimentError, ExperimentSpec, read_experiment
from core.runs.run_dir import atomic_write_text

ARCHIVED_FILES: tuple[str, ...] = (
    "metrics.csv",
    "summary.json",
    "config.yaml",
    "command.txt",
    "sb3_hyperparams.json",
)
"""The files of a done cell an archive keeps (those a cell lacks are skipped)."""

MERGED_KEYS: tuple[str, ...] = ("methods", "seeds", "description")
"""Experiment keys two pieces of one archive may differ in (methods and seeds are united)."""


@dataclass(frozen=True)
class ArchiveResult:
    directory: Path
    """``DEST/<experiment>``."""
    cells: tuple[str, ...]
    """``label/reward/seed-s`` of every cell copied."""


def archive_experiment(
    source: Path | str, dest: Path | str, experiment_file: Path | str | None = None
) -> ArchiveResult:
    """Copy the done cells of the experiment folder ``source`` into ``dest/<name>`` (module docstring).

    ``experiment_file`` is the file the cells belong to; by default the folder's experiment.yaml, which is the
    file of its *last* run (a run of a subset of a grid's methods or seeds into the same folder leaves only
    that subset there). Only cells of its methods and seeds are archived. Raises :class:`ExperimentError` when
    ``source`` holds no experiment or the archive there is of a different grid."""
    root = find_experiment_dir(source)
    spec = read_experiment(experiment_file if experiment_file is not None else root / EXPERIMENT_FILE)
    target = Path(dest) / spec.name
    stored = target / EXPERIMENT_FILE
    merged = merge_pieces(read_experiment(stored), spec) if stored.is_file() else spec
    copied: list[str] = []
    for label, reward, seed in itertools.product(
        [method.label for method in spec.methods], spec.rewards, spec.seeds
    ):
        run_dir = cell_dir(root, label, reward, seed)
        if cell_state(run_dir) != "done":
            continue
        relative = run_dir.relative_to(root)
        out = target / relative
        out.mkdir(parents=True, exist_ok=True)
        for name in ARCHIVED_FILES:
            if (run_dir / name).is_file():
                shutil.copyfile(run_dir / name, out / name)
        copied.append(relative.as_posix())
    target.mkdir(parents=True, exist_ok=True)
    atomic_write_text(stored, merged.to_yaml())
    return ArchiveResult(target, tuple(copied))


def merge_pieces(archived: ExperimentSpec, piece: ExperimentSpec) -> ExperimentSpec:
    """One experiment from two pieces of one grid: methods united by label (``piece`` wins on a label both
    name), seeds united; any other difference is an :class:`ExperimentError` naming the key."""
    old, new = archived.to_dict(), piece.to_dict()
    for key in sorted({*old, *new} - set(MERGED_KEYS)):
        if old.get(key) != new.get(key):
            raise ExperimentError(
                f"the archive of {archived.name!r} has {key}={old.get(key)!r}, this run {new.get(key)!r}: "
                "not pieces of one grid (archive it under another name)"
            )
    labels = {method.label for method in piece.methods}
    methods = tuple(m for m in archived.methods if m.label not in labels) + piece.methods
    seeds = tuple(sorted({*archived.seeds, *piece.seeds}))
    return dataclasses.replace(piece, methods=methods, seeds=seeds)


def restore_archive(archive: Path | str, spec: ExperimentSpec, out: Path | str) -> tuple[str, ...]:
    """Copy the done cells of ``spec`` archived in ``archive`` (``DEST/<name>`` or ``DEST``) into
    ``out/<name>`` wherever that cell has not started (neither done nor resumable there); returns their keys.

    A later run into ``out`` then skips them. An existing folder that holds no archive of ``spec`` yet
    restores nothing, so one command (``--from-archive R --archive-to R``) serves a grid's first day and every
    later one; a folder that does not exist is an error (a mistyped path). All or nothing: raises
    :class:`ExperimentError`, copying nothing, when the archive is of another grid (:func:`merge_pieces`) or
    one of its cells ran with settings ``spec`` no longer gives (the check a resumed cell gets,
    :func:`~core.experiments.cells.settings_conflict`)."""
    archive = Path(archive)
    source = _archive_dir(archive, spec.name)
    if source is None:
        if archive.is_dir():
            return ()
        raise ExperimentError(f"no archive of {spec.name!r} in {archive} (neither {archive} nor "
                              f"{archive / spec.name} holds one)")
    merge_pieces(read_experiment(source / EXPERIMENT_FILE), spec)
    pending: list[tuple[Path, Path]] = []
    keys: list[str] = []
    for cell in expand_cells(spec, out):
        archived = dataclasses.replace(cell, run_dir=cell_dir(source, cell.label, cell.reward, cell.seed))
        if cell_state(archived.run_dir) != "done" or cell_state(cell.run_dir) != "new":
            continue
        reason = settings_conflict(archived)
        if reason is not None:
            raise ExperimentError(
                f"the archived cell {cell.key} in {archived.run_dir} ran with other settings: {reason}"
            )
        pending.append((archived.run_dir, cell.run_dir))
        keys.append(cell.key)
    for archived_dir, run_dir in pending:
        clear_unresumable(run_dir)
        run_dir.mkdir(parents=True, exist_ok=True)
        for name in ARCHIVED_FILES:
            if (archived_dir / name).is_file():
                shutil.copyfile(archived_dir / name, run_dir / name)
    return tuple(keys)


def _archive_dir(path: Path, name: str) -> Path | None:
    """``path`` if it is an archive of the experiment ``name``, else ``path/name`` if that is; else None."""
    for candidate in (path, path / name):
        if (candidate / EXPERIMENT_FILE).is_file():
            return candidate
    return None
