"""The artifact store: a folder (the artifact root) that every stored file lives under.

Registered policy files go to `policies/<name>/v<version>/...`; the job service keeps job run
directories in `jobs/<id>/`. `ArtifactStore.confine` is the one gate for turning a user-supplied
relative path into a filesystem path: absolute paths, `..` segments, percent-encoded variants that
survived decoding, NUL bytes and symlinks that resolve outside the root are all refused.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import uuid
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from urllib.parse import unquote

from registry.errors import PathOutsideRoot

CHECKPOINT_SUFFIXES = (".pt", ".pth")
_SEGMENT = r"[A-Za-z0-9_][A-Za-z0-9_.,+=@-]{0,127}"
ARTIFACT_NAME = re.compile(rf"^{_SEGMENT}(?:/{_SEGMENT}){{0,15}}$")
"""The names a download URL takes: relative, up to 16 segments, none hidden (leading `.`), no `..`, no `%`,
backslash or colon. Every file a run directory or the store holds is named so (our own file names), and
each such name passes `confine`, so the OpenAPI schema can state it exactly."""


def artifact_kind(name: str) -> str:
    """Classify a stored file by name: checkpoint, onnx, config, metrics, summary, image or other."""
    lower = name.lower()
    if lower.endswith(CHECKPOINT_SUFFIXES):
        return "checkpoint"
    if lower.endswith(".onnx"):
        return "onnx"
    base = PurePosixPath(lower).name
    if base in ("config.yaml", "config.yml", "config.json"):
        return "config"
    if base.endswith(".csv"):
        return "metrics"
    if base == "summary.json":
        return "summary"
    if base.endswith((".png", ".jpg", ".jpeg", ".svg")):
        return "image"
    return "other"


def sha256_of(path: Path, chunk: int = 1 << 20) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while block := handle.read(chunk):
            digest.update(block)
    return digest.hexdigest()


@dataclass(frozen=True)
class StoredFile:
    name: str  # path relative to the folder it was listed from, POSIX separators
    path: Path  # absolute path on disk
    size: int
    kind: str


class ArtifactStore:
    """A root folder; every path it hands out is checked to stay inside it."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root).expanduser().resolve()
        self.root.mkdir(parents=True, exist_ok=True)

    def confine(self, relative: str | os.PathLike[str], *, base: Path | None = None) -> Path:
        """The absolute path of `relative` under `base` (default: the root), refusing escapes."""
        text = os.fspath(relative)
        base_dir = (base or self.root).resolve()
        if not base_dir.is_relative_to(self.root):
            raise PathOutsideRoot(f"base folder {base_dir} is outside the artifact root")
        decoded = text
        for _ in range(3):  # undo double/triple percent-encoding an attacker may have layered
            decoded = unquote(decoded)
        if "\x00" in decoded or not decoded.strip():
            raise PathOutsideRoot(f"invalid artifact path {text!r}")
        candidate = PurePosixPath(decoded.replace("\\", "/"))
        if candidate.is_absolute() or decoded.startswith(("/", "\\")) or ":" in candidate.parts[0]:
            raise PathOutsideRoot(f"artifact path {text!r} must be relative to the artifact root")
        if any(part == ".." for part in candidate.parts):
            raise PathOutsideRoot(f"artifact path {text!r} leaves the artifact root")
        resolved = (base_dir / Path(*candidate.parts)).resolve()
        if not resolved.is_relative_to(base_dir):
            raise PathOutsideRoot(f"artifact path {text!r} leaves the artifact root")
        return resolved

    def relative(self, path: Path) -> str:
        """`path` as a POSIX path relative to the root (it must be inside)."""
        resolved = Path(path).resolve()
        if not resolved.is_relative_to(self.root):
            raise PathOutsideRoot(f"{path} is outside the artifact root {self.root}")
        return resolved.relative_to(self.root).as_posix()

    def staging_dir(self, area: str) -> Path:
        """A fresh hidden folder under `area` to assemble files before an atomic rename."""
        folder = self.root / area / f".staging-{uuid.uuid4().hex}"
        folder.mkdir(parents=True)
        return folder

    @staticmethod
    def list_files(folder: Path) -> list[StoredFile]:
        """Regular files below `folder` (symlinks and hidden entries skipped), sorted by name."""
        folder = Path(folder)
        if not folder.is_dir():
            return []
        found: list[StoredFile] = []
        for dirpath, dirnames, filenames in os.walk(folder):
            dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and not d.startswith("__"))
            for filename in sorted(filenames):
                if filename.startswith("."):
                    continue
                path = Path(dirpath) / filename
                if path.is_symlink() or not path.is_file():
                    continue
                name = path.relative_to(folder).as_posix()
                found.append(
                    StoredFile(name=name, path=path, size=path.stat().st_size, kind=artifact_kind(name))
                )
        return found

    @staticmethod
    def copy_tree(files: list[StoredFile], destination: Path) -> None:
        for stored in files:
            target = destination / stored.name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(stored.path, target)

    @staticmethod
    def remove_tree(folder: Path) -> None:
        shutil.rmtree(folder, ignore_errors=True)
