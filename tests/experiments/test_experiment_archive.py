"""An archive keeps what a report reads and nothing heavier; a grid archived in two pieces reports exactly
like the whole grid; pieces of different grids are refused with one line; a grid goes on from its archive."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from core.experiments import build_report, load_experiment
from core.experiments.archive import archive_experiment, restore_archive
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


@pytest.mark.timeout(1800)  # two real tiny cells in worker processes; a loaded 2-core machine can be slow
def test_a_grid_goes_on_from_its_archive_alone(tmp_path: Path, write_experiment) -> None:
    """Seed 0 ran on one machine and only its archive was kept; on another, `run --from-archive` restores
    it (skipped, its numbers unchanged) and runs seed 1 alone. An archived cell whose settings the experiment
    no longer gives is refused before anything is copied, as a resumed cell would be."""
    one_method = [{"label": "DDPG", "algo": "ddpg"}]
    first_day = write_experiment("day1.yaml", methods=one_method, seeds=[0])
    results = str(tmp_path / "results")
    day1 = ["experiment", "run", str(first_day), "--out", str(tmp_path / "day1"), "--workers", "1"]
    assert CliRunner().invoke(app, [*day1, "--archive-to", results]).exit_code == 0
    archived = tmp_path / "results" / "tiny" / "DDPG" / "dense" / "seed-0"
    assert (archived / "summary.json").is_file() and not (archived / "checkpoints").exists()

    whole = write_experiment("whole.yaml", methods=one_method, seeds=[0, 1])
    args = ["experiment", "run", str(whole), "--out", str(tmp_path / "day2"), "--workers", "1", "--json"]
    result = CliRunner().invoke(app, [*args, "--from-archive", results, "--archive-to", results])
    assert result.exit_code == 0, result.output
    assert "1 finished cells restored" in result.stderr
    outcome = json.loads(result.stdout.strip().splitlines()[-1])
    assert outcome["skipped"] == ["DDPG/dense/seed-0"] and outcome["done"] == ["DDPG/dense/seed-1"]
    restored = tmp_path / "day2" / "tiny" / "DDPG" / "dense" / "seed-0"
    assert (restored / "metrics.csv").read_bytes() == (archived / "metrics.csv").read_bytes()
    assert build_report(tmp_path / "results" / "tiny")["done"] == 2  # the archive holds the whole grid now
    assert restore_archive(tmp_path / "results" / "tiny", load_experiment(whole), tmp_path / "day2") == ()

    config = yaml.safe_load((archived / "config.yaml").read_text())
    config["agent"]["batch_size"] = 16
    (archived / "config.yaml").write_text(yaml.safe_dump(config))
    with pytest.raises(ExperimentError, match=r"agent\.batch_size was 16"):
        restore_archive(tmp_path / "results", load_experiment(whole), tmp_path / "day3")
    assert not (tmp_path / "day3").exists()
    other_grid = write_experiment("other.yaml", methods=one_method, seeds=[0, 1], steps=200)
    with pytest.raises(ExperimentError, match="steps=100"):
        restore_archive(tmp_path / "results", load_experiment(other_grid), tmp_path / "day3")
    args = ["experiment", "run", str(whole), "--from-archive", str(tmp_path / "no")]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2 and "no archive of 'tiny'" in result.stderr
    (tmp_path / "empty").mkdir()  # a folder with nothing of this grid yet: its first day, nothing restored
    assert restore_archive(tmp_path / "empty", load_experiment(whole), tmp_path / "day5") == ()
    assert not (tmp_path / "day5").exists()
    day4 = ["experiment", "run", str(other_grid), "--out", str(tmp_path / "day4"), "--archive-to", results]
    result = CliRunner().invoke(app, day4)  # refused before any cell trains
    assert result.exit_code == 2 and "steps=100" in result.stderr
    assert not list((tmp_path / "day4").glob("tiny/*/*/seed-*"))
