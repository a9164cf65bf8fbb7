"""The registry's Python API: versions from 1, aliases, tags, lineage, atomic registration."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
import torch

from registry import (
    InvalidName,
    InvalidRunDirectory,
    PolicyNotFound,
    PolicyRegistry,
    RegistrySettings,
    VersionNotFound,
    resolve_checkpoint,
)
from registry.artifact_store import sha256_of
from tests.utils.run_dirs import make_run_dir


def test_versions_count_from_one_and_copy_files(policy_registry: PolicyRegistry, tmp_path: Path) -> None:
    run = make_run_dir(tmp_path / "run", seed=1)
    first = policy_registry.register_run("grasp", run, source_job_id=7, tags={"algo": "i2a"})
    second = policy_registry.register_run("grasp", make_run_dir(tmp_path / "run2", seed=2))
    assert (first.version, second.version) == (1, 2)
    assert first.source_job_id == 7 and first.tags == {"algo": "i2a"}
    assert first.config["seed"] == 1 and first.metrics["final_success_rate"] == 0.5
    names = [a.name for a in first.artifacts]
    assert names == sorted(names) and "checkpoints/best.pt" in names and "metrics.csv" in names
    # files are copies inside the store, byte-identical to the run directory's
    best = first.artifact("checkpoints/best.pt")
    assert best.path.is_relative_to(policy_registry.store.root)
    assert best.sha256 == sha256_of(run / "checkpoints" / "best.pt")
    assert first.checkpoint == best.path
    loaded = torch.load(first.checkpoint, weights_only=True)
    assert loaded["episode"] == 3
    # the registered copy survives the run directory's removal
    (run / "checkpoints" / "best.pt").unlink()
    assert policy_registry.resolve("grasp@1").checkpoint.is_file()


def test_replay_buffer_and_worker_log_are_not_registered(
    policy_registry: PolicyRegistry, tmp_path: Path
) -> None:
    run = make_run_dir(tmp_path / "run")
    (run / "checkpoints" / "replay.pt").write_bytes(b"replay")
    (run / "worker.log").write_text("log")
    names = {a.name for a in policy_registry.register_run("grasp", run).artifacts}
    assert "checkpoints/replay.pt" not in names and "worker.log" not in names
    assert {"checkpoints/best.pt", "checkpoints/latest.pt", "config.yaml"} <= names


def test_resolve_by_version_alias_and_latest(policy_registry: PolicyRegistry, tmp_path: Path) -> None:
    for seed in range(3):
        policy_registry.register_run("grasp", make_run_dir(tmp_path / f"r{seed}", seed=seed))
    assert policy_registry.resolve("grasp").version == 3
    assert policy_registry.resolve("grasp@latest").version == 3
    assert policy_registry.resolve("grasp@2").config["seed"] == 1
    policy_registry.set_alias("grasp", "champion", 1)
    assert policy_registry.resolve("grasp@champion").version == 1
    policy_registry.set_alias("grasp", "champion", 2)  # aliases are mutable pointers
    assert policy_registry.resolve("grasp@champion").version == 2
    assert policy_registry.get_version("grasp", 2).aliases == ["champion"]
    assert policy_registry.get_policy("grasp").aliases == {"champion": 2}
    policy_registry.delete_alias("grasp", "champion")
    with pytest.raises(VersionNotFound, match="champion"):
        policy_registry.resolve("grasp@champion")


def test_user_errors_name_the_culprit(policy_registry: PolicyRegistry, tmp_path: Path) -> None:
    with pytest.raises(PolicyNotFound, match="nope"):
        policy_registry.resolve("nope@1")
    policy_registry.register_run("grasp", make_run_dir(tmp_path / "r"))
    with pytest.raises(VersionNotFound, match="version 9"):
        policy_registry.resolve("grasp@9")
    with pytest.raises(VersionNotFound, match="version 9"):
        policy_registry.set_alias("grasp", "champion", 9)
    with pytest.raises(InvalidName, match="reserved"):
        policy_registry.set_alias("grasp", "latest", 1)
    with pytest.raises(InvalidName):
        policy_registry.register_run("bad/name", make_run_dir(tmp_path / "r2"))
    with pytest.raises(InvalidRunDirectory, match="no checkpoint"):
        policy_registry.register_run("grasp", make_run_dir(tmp_path / "empty", with_checkpoint=False))
    with pytest.raises(InvalidRunDirectory, match="does not exist"):
        policy_registry.register_run("grasp", tmp_path / "missing")


def test_failed_registration_leaves_nothing_behind(policy_registry: PolicyRegistry, tmp_path: Path) -> None:
    with pytest.raises(PolicyNotFound):
        policy_registry.register_run("grasp", make_run_dir(tmp_path / "r"), parent="unknown@1")
    assert policy_registry.list_policies() == []
    leftovers = list((policy_registry.store.root).rglob("*"))
    assert not any(p.is_file() for p in leftovers)


def test_lineage_and_tags(policy_registry: PolicyRegistry, tmp_path: Path) -> None:
    policy_registry.register_run("grasp", make_run_dir(tmp_path / "r"))
    aligned = policy_registry.register_run("grasp-real", make_run_dir(tmp_path / "a"), parent="grasp@1")
    assert aligned.parent == "grasp@1"
    again = policy_registry.register_run("grasp-real", make_run_dir(tmp_path / "b"), parent="grasp-real@1")
    assert [v.ref for v in policy_registry.lineage(again.ref)] == ["grasp-real@2", "grasp-real@1", "grasp@1"]
    tagged = policy_registry.set_tag("grasp-real@2", "domain", "real")
    assert tagged.tags == {"domain": "real"}
    listing = {p.name: p.latest_version for p in policy_registry.list_policies()}
    assert listing == {"grasp": 1, "grasp-real": 2}


def test_overviews_and_versions_from_a_job(policy_registry: PolicyRegistry, tmp_path: Path) -> None:
    """What the dashboard lists without SQL of its own: per policy its version count and newest version's
    time and job; per job the versions registered from it."""
    assert policy_registry.policy_overviews() == {} and policy_registry.versions_from_job(7) == []
    policy_registry.register_run("grasp", make_run_dir(tmp_path / "r1"), source_job_id=7)
    policy_registry.register_run("grasp", make_run_dir(tmp_path / "r2"), source_job_id=8)
    policy_registry.register_run("other", make_run_dir(tmp_path / "r3"), source_job_id=7)
    overviews = policy_registry.policy_overviews()
    newest = policy_registry.resolve("grasp")
    assert (overviews["grasp"].versions, overviews["grasp"].latest_source_job_id) == (2, 8)
    assert overviews["grasp"].latest_created_at == newest.created_at
    assert (overviews["other"].versions, overviews["other"].latest_source_job_id) == (1, 7)
    assert policy_registry.versions_from_job(7) == ["grasp@1", "other@1"]


def test_add_onnx_artifact(policy_registry: PolicyRegistry, tmp_path: Path) -> None:
    policy_registry.register_run("grasp", make_run_dir(tmp_path / "r"))
    onnx = tmp_path / "policy.onnx"
    onnx.write_bytes(b"onnx-bytes")
    record = policy_registry.add_artifact("grasp@1", onnx)
    assert record.onnx is not None and record.onnx.read_bytes() == b"onnx-bytes"
    assert record.artifact("policy.onnx").kind == "onnx"
    with pytest.raises(InvalidRunDirectory):
        policy_registry.add_artifact("grasp@1", tmp_path / "missing.onnx")


def test_concurrent_registrations_get_distinct_consecutive_versions(
    policy_registry: PolicyRegistry, tmp_path: Path
) -> None:
    runs = [make_run_dir(tmp_path / f"r{i}", seed=i) for i in range(6)]
    versions: list[int] = []
    errors: list[BaseException] = []

    def register(run: Path) -> None:
        try:
            versions.append(policy_registry.register_run("grasp", run).version)
        except BaseException as error:  # pragma: no cover - reported below
            errors.append(error)

    threads = [threading.Thread(target=register, args=(run,)) for run in runs]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert sorted(versions) == [1, 2, 3, 4, 5, 6]
    seeds = {policy_registry.get_version("grasp", v).config["seed"] for v in versions}
    assert seeds == set(range(6))


def test_resolve_checkpoint_takes_paths_or_references(tmp_path: Path) -> None:
    settings = RegistrySettings(database_url=f"sqlite:///{tmp_path / 'r.db'}", artifacts=tmp_path / "store")
    run = make_run_dir(tmp_path / "run")
    assert resolve_checkpoint(str(run), settings) == run / "checkpoints" / "best.pt"
    assert resolve_checkpoint(str(run / "checkpoints" / "latest.pt"), settings).name == "latest.pt"
    registry = PolicyRegistry.from_settings(settings)
    registry.register_run("grasp", run)
    registry.set_alias("grasp", "champion", 1)
    path = resolve_checkpoint("grasp@champion", settings)
    assert path.is_relative_to(settings.artifacts.resolve()) and path.name == "best.pt"
    with pytest.raises(InvalidName, match="neither an existing path"):
        resolve_checkpoint("no such/thing", settings)
