"""Reading a training run directory (as `core.runs.trainer.train` writes it) for registration.

A run directory holds `config.yaml` (the resolved config), `summary.json` (the metrics summary),
`metrics.csv`, `checkpoints/latest.pt` and `checkpoints/best.pt`, and maybe an exported `*.onnx`.
Decision: a directory is registrable when it holds at least one checkpoint (`*.pt`/`*.pth`) or an
ONNX file; config and summary are recorded when present (an aligned or imported policy may lack them).
Resume-only state is not copied into the registry: `checkpoints/replay.pt` (the replay buffer,
hundreds of MB for a full run) and the job service's `worker.log`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from registry.artifact_store import ArtifactStore, StoredFile
from registry.errors import InvalidRunDirectory

NOT_REGISTERED = frozenset({"checkpoints/replay.pt", "worker.log"})


@dataclass(frozen=True)
class RunDirectoryContents:
    path: Path
    files: list[StoredFile]
    config: dict[str, Any] = field(default_factory=dict)
    metrics: dict[str, Any] = field(default_factory=dict)


def _read_mapping(path: Path, what: str) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
        data = json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
    except (OSError, ValueError, yaml.YAMLError) as error:
        raise InvalidRunDirectory(f"cannot read the {what} {path}: {error}") from error
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise InvalidRunDirectory(f"the {what} {path} is not a mapping")
    return data


def read_run_directory(path: Path) -> RunDirectoryContents:
    """List and parse a run directory, or raise InvalidRunDirectory naming what is missing."""
    folder = Path(path).expanduser()
    if not folder.exists():
        raise InvalidRunDirectory(f"run directory {folder} does not exist")
    if not folder.is_dir():
        raise InvalidRunDirectory(f"{folder} is not a directory")
    files = [f for f in ArtifactStore.list_files(folder) if f.name not in NOT_REGISTERED]
    if not any(f.kind in ("checkpoint", "onnx") for f in files):
        raise InvalidRunDirectory(f"run directory {folder} holds no checkpoint (*.pt) and no *.onnx file")
    config: dict[str, Any] = {}
    for name in ("config.yaml", "config.yml", "config.json"):
        if (folder / name).is_file():
            config = _read_mapping(folder / name, "config")
            break
    metrics = _read_mapping(folder / "summary.json", "summary") if (folder / "summary.json").is_file() else {}
    return RunDirectoryContents(
        path=folder.resolve(), files=files, config=_jsonable(config), metrics=_jsonable(metrics)
    )


def _jsonable(value: Any) -> Any:
    """Round-trip through JSON so the stored summary holds only JSON types."""
    return json.loads(json.dumps(value, default=str))
