"""`dualsys export` / `dualsys eval`: run directories and registry references, JSON, one-line errors."""

from __future__ import annotations

import json

import pytest
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


@pytest.fixture()
def registry_paths(tmp_path, tiny_run):
    db, artifacts = tmp_path / "reg.db", tmp_path / "artifacts"
    registry = PolicyRegistry.open(f"sqlite:///{db}", artifacts)
    registry.register_run("grasp", tiny_run)
    registry.database.dispose()
    return db, artifacts


def test_export_a_registry_version_stores_the_onnx_as_its_artifact(tmp_path, registry_paths):
    db, artifacts = registry_paths
    out = tmp_path / "policy.onnx"
    result = invoke("export", "--policy", "grasp@1", "--out", str(out), "--db", str(db),
                    "--artifacts", str(artifacts), "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout.strip().splitlines()[-1])
    assert data["registered_artifact_of"] == "grasp@1" and data["max_abs_diff"] <= 1e-4
    assert data["input_name"] == "obs" and data["output_name"] == "action" and data["opset"] == 17
    registry = PolicyRegistry.open(f"sqlite:///{db}", artifacts)
    stored = registry.resolve("grasp@1").onnx
    registry.database.dispose()
    assert stored is not None and stored.read_bytes() == out.read_bytes()

    evaluated = invoke("eval", "--policy", "grasp@1", "--onnx", "--trials", "2", "--max-steps", "3",
                       "--db", str(db), "--artifacts", str(artifacts), "--json")
    assert evaluated.exit_code == 0, evaluated.output
    report = json.loads(evaluated.stdout)
    assert report["trials"] == 2 and all(t["steps"] <= 3 for t in report["per_trial"])


def test_eval_a_run_directory_prints_a_table_and_json(tiny_run):
    text = invoke("eval", "--policy", str(tiny_run), "--trials", "2", "--max-steps", "2", "--domain", "real")
    assert text.exit_code == 0, text.output
    assert "grasp trials" in text.stdout and "95% Wilson interval" in text.stdout
    result = invoke("eval", "--policy", str(tiny_run), "--trials", "2", "--max-steps", "2", "--json")
    data = json.loads(result.stdout)
    assert set(data) >= {"trials", "successes", "success_rate", "ci_low", "ci_high", "per_trial"}
    assert data["trials"] == 2 and data["ci_low"] <= data["success_rate"] <= data["ci_high"]


def test_bad_input_is_one_line_and_exit_2(tmp_path, tiny_run):
    one_line_error(invoke("eval", "--policy", str(tmp_path / "nowhere"), "--trials", "1"), "not found")
    one_line_error(invoke("eval", "--policy", "ghost@3", "--db", str(tmp_path / "none.db"), "--trials", "1"),
                   "no policy registry")
    assert not (tmp_path / "none.db").exists()
    one_line_error(invoke("eval", "--policy", str(tiny_run), "--domain", "moon"), "unknown domain")
    one_line_error(invoke("eval", "--policy", str(tiny_run), "--shift", str(tmp_path / "s.yaml")),
                   "camera-shift file not found")
    (tmp_path / "bad.yaml").write_text("yaw_deg: 1\nwobble: 2\n")
    one_line_error(invoke("eval", "--policy", str(tiny_run), "--domain", "real", "--shift",
                          str(tmp_path / "bad.yaml")), "wobble")
    one_line_error(invoke("export", "--policy", str(tmp_path / "nowhere"), "--out", str(tmp_path / "p.onnx")),
                   "not found")
    assert not (tmp_path / "p.onnx").exists()


def test_unknown_registry_policy_is_a_one_line_error(registry_paths):
    db, artifacts = registry_paths
    one_line_error(invoke("eval", "--policy", "grasp@9", "--db", str(db), "--artifacts", str(artifacts)),
                   "grasp")
    one_line_error(invoke("eval", "--policy", "other", "--db", str(db), "--artifacts", str(artifacts)),
                   "other")


def test_bench_onnx_prints_json():
    result = invoke("bench", "onnx", "--repeats", "20", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["onnx_ms_per_image_batch1"] > 0 and data["torch_ms_per_image_batch1"] > 0
    assert isinstance(data["meets_goal"], bool)
