"""`dualsys pairs` / `dualsys align`: JSON output, registry lineage, one-line errors that write nothing."""

from __future__ import annotations

import json
import shutil

import pytest
from PIL import Image
from typer.testing import CliRunner

from dualsys_cli.main import app
from registry import PolicyRegistry


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


def one_line_error(result, fragment: str) -> None:
    assert result.exit_code == 2, result.output
    assert result.stderr.strip().count("\n") == 0, result.stderr
    assert result.stderr.startswith("error: ") and fragment in result.stderr, result.stderr
    assert "Traceback" not in result.output


@pytest.fixture(scope="module")
def pair_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "pairs"
    result = invoke("pairs", "--n", "12", "--out", str(out), "--seed", "2", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["count"] == 12 and data["mean_abs_pixel_diff"] > 0
    return out


def registry_at(tmp_path):
    return PolicyRegistry.open(f"sqlite:///{tmp_path / 'reg.db'}", tmp_path / "artifacts")


def test_align_a_run_dir_with_name_registers_source_and_aligned_child(tmp_path, tiny_run, pair_set):
    result = invoke("align", "--policy", str(tiny_run), "--pairs", str(pair_set), "--epochs", "2",
                    "--batch-size", "8", "--name", "grasp", "--out", str(tmp_path / "aligned"),
                    "--db", str(tmp_path / "reg.db"), "--artifacts", str(tmp_path / "artifacts"), "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["registered"] == "grasp@2" and data["parent"] == "grasp@1"
    assert data["epochs"] == 2 and data["heldout_pairs"] == 1 and data["pairs"] == 12
    registry = registry_at(tmp_path)
    try:
        aligned, source = registry.resolve("grasp@2"), registry.resolve("grasp@1")
        assert aligned.parent == "grasp@1" and aligned.tags["aligned"] == "true"
        assert source.tags["role"] == "source" and aligned.checkpoint is not None
        assert aligned.metrics["heldout_distance_after"] == data["heldout_distance_after"]
    finally:
        registry.database.dispose()

    again = invoke("align", "--policy", "grasp@1", "--pairs", str(pair_set), "--epochs", "1",
                   "--batch-size", "8", "--out", str(tmp_path / "aligned-2"),
                   "--db", str(tmp_path / "reg.db"), "--artifacts", str(tmp_path / "artifacts"))
    assert again.exit_code == 0, again.output
    assert "held-out latent distance" in again.stdout
    assert "registered grasp@3 (parent grasp@1)" in again.stdout


def test_align_without_registry_writes_only_the_run_dir(tmp_path, tiny_run, pair_set):
    result = invoke("align", "--policy", str(tiny_run), "--pairs", str(pair_set), "--epochs", "1",
                    "--batch-size", "8", "--out", str(tmp_path / "aligned"), "--json")
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["registered"] is None
    assert (tmp_path / "aligned" / "checkpoints" / "best.pt").is_file()
    evaluated = invoke("eval", "--policy", str(tmp_path / "aligned"), "--trials", "1", "--max-steps", "2",
                       "--domain", "real", "--json")
    assert evaluated.exit_code == 0 and json.loads(evaluated.stdout)["trials"] == 1


def test_each_bad_input_is_one_line_and_writes_nothing(tmp_path, tiny_run, pair_set):
    out = tmp_path / "never"

    def align(pairs, policy=str(tiny_run), *extra):
        return invoke("align", "--policy", policy, "--pairs", str(pairs), "--epochs", "1", "--out", str(out),
                      *extra)

    (tmp_path / "empty" / "sim").mkdir(parents=True)
    (tmp_path / "empty" / "real").mkdir()
    one_line_error(align(tmp_path / "empty"), "no image pairs")
    one_line_error(align(tmp_path / "absent"), "does not exist")

    unpaired = tmp_path / "unpaired"
    shutil.copytree(pair_set, unpaired)
    (unpaired / "sim" / "000005.png").unlink()
    one_line_error(align(unpaired), "unpaired")

    wrong = tmp_path / "wrong-size"
    shutil.copytree(pair_set, wrong)
    Image.new("RGB", (128, 64)).save(wrong / "real" / "000001.png")
    one_line_error(align(wrong), "128x64")

    channels = tmp_path / "channels"
    shutil.copytree(pair_set, channels)
    Image.new("RGBA", (64, 32)).save(channels / "sim" / "000002.png")
    one_line_error(align(channels), "4 channel(s)")

    unreadable = tmp_path / "unreadable"
    shutil.copytree(pair_set, unreadable)
    (unreadable / "real" / "000000.png").write_bytes(b"garbage")
    one_line_error(align(unreadable), "cannot read image")

    one_line_error(align(pair_set, str(tmp_path / "no-such-run")), "not found")
    one_line_error(align(pair_set, "ghost@1", "--db", str(tmp_path / "none.db")), "not found")
    one_line_error(align(pair_set, str(tiny_run), "--name", "bad name!"), "invalid policy name")
    assert not out.exists() and not (tmp_path / "none.db").exists()

    one_line_error(invoke("pairs", "--n", "2", "--out", str(pair_set)), "not an empty folder")
    one_line_error(invoke("pairs", "--n", "2", "--out", str(out), "--shift", str(tmp_path / "x.yaml")),
                   "camera-shift file not found")
    assert not out.exists()
