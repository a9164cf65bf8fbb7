"""An archive keeps what a report reads and nothing heavier; a grid archived in two pieces reports exactly
like the whole grid; pieces of different grids are refused with one line."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from core.experiments import build_report
from core.experiments.archive import archive_experiment
from core.experiments.spec import ExperimentError
from dualsys_cli.main import app
from tests.experiments.test_experiment_report import SEEDS, made_up, write_cell  # noqa: F401 (fixture)


def _piece(whole: Path, where: Path, seeds: list[int]) -> Path:
    """A copy of the grid ``whole`` that ran only ``seeds`` (its experiment.yaml says so)."""
    piece = where / "made-up"
    shutil.copytree(whole, piece, ignore=shutil.ignore_patterns("seed-*"))
    spec = yaml.safe_load((whole / "experiment.yaml").read_text())
    (piece / "experiment.yaml").write_text(yaml.safe_dump({**spec, "seeds": seeds}))
    for cell in whole.glob("*/*/seed-*"):
        if int(cell.name.removeprefix("seed-")) in seeds:
            shutil.copytree(cell, piece / cell.relative_to(whole))
    return piece


def test_two_pieces_archive_into_the_report_of_the_whole_grid(made_up: Path, tmp_path: Path) -> None:  # noqa: F811
    first = _piece(made_up, tmp_path / "day1", [0, 1])
    second = _piece(made_up, tmp_path / "day2", [2, 3])
    write_cell(second, "B", "sparse", 9, [-1.0] * 20, 0.0, stopped=True)  # interrupted: not archived
    archive_experiment(first, tmp_path / "results")
    result = archive_experiment(second, tmp_path / "results")
    assert len(result.cells) == 4 and "B/sparse/seed-9" not in result.cells
    archived = tmp_path / "results" / "made-up"
    assert yaml.safe_load((archived / "experiment.yaml").read_text())["seeds"] == list(SEEDS)
    assert not list(archived.rglob("checkpoints")) and not (archived / "B" / "sparse" / "seed-9").exists()
    assert build_report(archived)["methods"] == build_report(made_up)["methods"]


def test_the_experiment_file_given_decides_which_cells_belong(made_up: Path, tmp_path: Path) -> None:  # noqa: F811
    """A run of one method into the grid's folder leaves only that method in its experiment.yaml; the whole
    file, given, archives every method's cells, and a file naming fewer archives fewer."""
    whole = tmp_path / "whole.yaml"
    shutil.copyfile(made_up / "experiment.yaml", whole)
    spec = yaml.safe_load(whole.read_text())
    only_m = {**spec, "methods": [m for m in spec["methods"] if m["label"] == "M"]}
    (made_up / "experiment.yaml").write_text(yaml.safe_dump(only_m))
    assert len(archive_experiment(made_up, tmp_path / "a").cells) == 4
    assert len(archive_experiment(made_up, tmp_path / "b", whole).cells) == 8


def test_pieces_of_different_grids_are_refused(made_up: Path, tmp_path: Path) -> None:  # noqa: F811
    archive_experiment(made_up, tmp_path / "results")
    other = _piece(made_up, tmp_path / "other", [0])
    spec = yaml.safe_load((other / "experiment.yaml").read_text())
    (other / "experiment.yaml").write_text(yaml.safe_dump({**spec, "steps": 6000}))
    with pytest.raises(ExperimentError, match="steps=3000"):
        archive_experiment(other, tmp_path / "results")
    result = CliRunner().invoke(app, ["experiment", "archive", str(other), "--to", str(tmp_path / "results")])
    assert result.exit_code == 2 and result.stderr.strip().count("\n") == 0
    result = CliRunner().invoke(app, ["experiment", "archive", str(made_up), "--to", str(tmp_path / "more")])
    assert result.exit_code == 0 and "8 finished cells archived" in result.stdout
