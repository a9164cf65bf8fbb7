"""Generate paired images (``dualsys pairs``): the same NicoGrasp state through the sim camera and the
real-camera stand-in, in the folder layout of :mod:`sim2real.pair_dataset`.

States: the glass at a random graspable position and the shoulder uniformly in its window, hand open — the
states a grasp trial visits (``core.deploy.render_paired_states``). The stand-in camera is
``core.envs.CameraShift`` (default: the env's), or one read from a YAML/JSON file (:func:`read_camera_shift`).

The folder is written atomically: everything goes to a hidden sibling folder that is renamed to ``out`` at
the end, so an interrupted run leaves no half-written pair set. ``out`` must not exist or be empty.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from core.deploy import render_paired_states
from core.envs import CameraShift
from sim2real.pair_dataset import MANIFEST_NAME, PAIRS_FORMAT, PairDataError


@dataclass(frozen=True)
class PairsReport:
    out: Path
    count: int
    seed: int
    camera_shift: dict[str, Any]
    mean_abs_pixel_diff: float
    """Mean |sim − real| over all pixels (0-255): how far apart the two cameras are."""

    def to_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "count": self.count, "seed": self.seed,
                "mean_abs_pixel_diff": self.mean_abs_pixel_diff}


def read_camera_shift(path: Path | str) -> CameraShift:
    """A ``CameraShift`` from a YAML or JSON file of its fields (see ``core.envs.CameraShift``)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"camera-shift file not found: {path}")
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ValueError(f"cannot parse camera-shift file {path}: {exc}".splitlines()[0]) from None
    if not isinstance(data, dict):
        raise ValueError(f"camera-shift file {path} must hold a mapping of CameraShift fields")
    try:
        return CameraShift.from_dict(data)
    except TypeError as exc:
        raise ValueError(f"bad camera shift in {path}: {exc}") from None


def _check_out(out: Path) -> None:
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise PairDataError(f"{out} already exists and is not an empty folder")


def generate_pairs(
    *,
    n: int,
    out: Path | str,
    seed: int = 0,
    camera_shift: CameraShift | None = None,
    on_image: Callable[[int], None] | None = None,
) -> PairsReport:
    """Render ``n`` paired images into ``out`` (``sim/NAME.png``, ``real/NAME.png``, ``manifest.json``)."""
    from PIL import Image

    out = Path(out)
    if n < 1:
        raise ValueError(f"--n must be >= 1, got {n}")
    _check_out(out)
    shift = camera_shift if camera_shift is not None else CameraShift()
    states = render_paired_states(n, seed=seed, camera_shift=shift, on_image=on_image)
    digits = max(6, len(str(n - 1)))
    names = [f"{i:0{digits}d}" for i in range(n)]
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    try:
        for side, images in (("sim", states.sim), ("real", states.real)):
            (staging / side).mkdir()
            for name, image in zip(names, images, strict=True):
                Image.fromarray(image).save(staging / side / f"{name}.png")  # uint8 H×W×3 is RGB
        manifest = {
            "format": PAIRS_FORMAT,
            "count": n,
            "seed": seed,
            "image_shape": list(states.sim.shape[1:]),
            "camera_shift": shift.to_dict(),
            "pairs": [{"name": name, "shoulder_deg": float(q), "glass_pos": [float(v) for v in pos]}
                      for name, q, pos in zip(names, states.shoulder_deg, states.glass_pos, strict=True)],
        }
        (staging / MANIFEST_NAME).write_text(json.dumps(manifest, indent=1) + "\n")
        _check_out(out)
        if out.exists():
            out.rmdir()
        staging.chmod(0o755)
        os.replace(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    diff = float(np.mean(np.abs(states.sim.astype(np.int16) - states.real.astype(np.int16))))
    return PairsReport(out=out, count=n, seed=seed, camera_shift=shift.to_dict(), mean_abs_pixel_diff=diff)
