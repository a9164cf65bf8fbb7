"""Writes the generated URDF descriptions to files PyBullet can load, cached by content hash."""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

from core.envs.robot_description import ArmGeometry, glass_urdf, robot_urdf, table_urdf

_BUILDERS = {"robot": robot_urdf, "table": table_urdf, "glass": glass_urdf}


def scene_file(kind: str, geometry: ArmGeometry) -> str:
    """Path of the URDF file for `kind` ("robot", "table" or "glass"), written atomically if missing."""
    text = _BUILDERS[kind](geometry)
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    folder = Path(tempfile.gettempdir()) / "dualsys-urdf"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{kind}-{digest}.urdf"
    if not path.exists():
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    return str(path)
