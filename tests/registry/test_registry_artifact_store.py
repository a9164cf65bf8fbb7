"""Artifact paths never leave the artifact root: `..`, absolute, encoded variants, symlinks."""

import os
from pathlib import Path

import pytest

from registry import PathOutsideRoot
from registry.artifact_store import ArtifactStore, artifact_kind


@pytest.fixture()
def store(tmp_path: Path) -> ArtifactStore:
    root = tmp_path / "root"
    (root / "jobs" / "1" / "checkpoints").mkdir(parents=True)
    (root / "jobs" / "1" / "checkpoints" / "best.pt").write_bytes(b"x")
    (tmp_path / "secret.txt").write_text("secret")
    return ArtifactStore(root)


def test_inside_paths_resolve(store: ArtifactStore) -> None:
    base = store.root / "jobs" / "1"
    assert store.confine("checkpoints/best.pt", base=base) == base / "checkpoints" / "best.pt"
    assert store.confine("checkpoints/./best.pt", base=base) == base / "checkpoints" / "best.pt"


@pytest.mark.parametrize(
    "attack",
    [
        "../secret.txt",
        "../../secret.txt",
        "checkpoints/../../../secret.txt",
        "/etc/passwd",
        "%2e%2e/%2e%2e/secret.txt",
        "%2e%2e%2f%2e%2e%2fsecret.txt",
        "%252e%252e%252fsecret.txt",
        "..%5c..%5csecret.txt",
        "..\\..\\secret.txt",
        "%2fetc%2fpasswd",
        "C:/Windows/win.ini",
        "checkpoints/best.pt\x00.txt",
        "",
    ],
)
def test_escapes_are_refused(store: ArtifactStore, attack: str) -> None:
    with pytest.raises(PathOutsideRoot):
        store.confine(attack, base=store.root / "jobs" / "1")


def test_symlink_out_of_root_is_refused(store: ArtifactStore, tmp_path: Path) -> None:
    os.symlink(tmp_path / "secret.txt", store.root / "jobs" / "1" / "link.txt")
    with pytest.raises(PathOutsideRoot):
        store.confine("link.txt", base=store.root / "jobs" / "1")
    assert [f.name for f in ArtifactStore.list_files(store.root / "jobs" / "1")] == ["checkpoints/best.pt"]


def test_base_outside_root_is_refused(store: ArtifactStore, tmp_path: Path) -> None:
    with pytest.raises(PathOutsideRoot):
        store.confine("secret.txt", base=tmp_path)


def test_artifact_kinds() -> None:
    assert artifact_kind("checkpoints/best.pt") == "checkpoint"
    assert artifact_kind("policy.onnx") == "onnx"
    assert artifact_kind("config.yaml") == "config"
    assert artifact_kind("metrics.csv") == "metrics"
    assert artifact_kind("summary.json") == "summary"
    assert artifact_kind("worker.log") == "other"
