"""Paired sim/real image folders: the layout, and loading with validation.

Layout (written by ``dualsys pairs``; a user's own pairs from a physical camera use the same one)::

    DIR/
      sim/NAME.png      the simulator camera's image of one joint configuration + object position
      real/NAME.png     the (real) camera's image of the same configuration, same NAME
      manifest.json     optional: {"format": "dualsys-pairs/1", "count", "seed", "camera_shift", "pairs"}

Images are 64×32 (width × height) RGB, 8 bits per channel; ``.png``, ``.jpg`` and ``.jpeg`` files are
images, a pair is two files with the same stem, other files (and hidden ones) are ignored. Every problem a
user can cause is reported before anything is trained or written: a missing or empty folder, names present
on one side only, an image of the wrong size or channel count, a file that cannot be decoded, a manifest
that is not JSON.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
IMAGE_SHAPE: tuple[int, int, int] = (32, 64, 3)
"""(H, W, C) of every image: NicoGrasp's observation."""
MANIFEST_NAME = "manifest.json"
PAIRS_FORMAT = "dualsys-pairs/1"


class PairDataError(ValueError):
    """A paired-image folder that cannot be used (one-line message naming the folder or file)."""


class PairFolderNotFound(PairDataError, FileNotFoundError):
    """The paired-image folder (or its sim/ or real/ part) does not exist."""


@dataclass(frozen=True)
class PairedImages:
    """Loaded pairs, in name order."""

    names: list[str]
    sim: np.ndarray
    """uint8 ``[N, 32, 64, 3]``."""
    real: np.ndarray
    """uint8 ``[N, 32, 64, 3]``."""
    manifest: dict

    def __len__(self) -> int:
        return len(self.names)


def _image_files(folder: Path) -> dict[str, Path]:
    if not folder.is_dir():
        raise PairFolderNotFound(f"{folder} does not exist (expected sim/ and real/ image folders)")
    files: dict[str, Path] = {}
    for path in sorted(folder.iterdir()):
        if path.name.startswith(".") or not path.is_file() or path.suffix.lower() not in IMAGE_SUFFIXES:
            continue
        if path.stem in files:
            raise PairDataError(f"{folder} holds two images named {path.stem!r} ({files[path.stem].name}, "
                                f"{path.name})")
        files[path.stem] = path
    return files


def read_image(path: Path, shape: tuple[int, int, int] = IMAGE_SHAPE) -> np.ndarray:
    """One image as uint8 ``[H, W, 3]``, or PairDataError naming the file and what is wrong."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            image.load()
            bands = image.getbands()
            width, height = image.size
            if len(bands) != shape[2] or image.mode != "RGB":
                raise PairDataError(f"{path} has {len(bands)} channel(s) (mode {image.mode}); expected "
                                    f"{shape[2]} (RGB)")
            if (height, width) != shape[:2]:
                raise PairDataError(f"{path} is {width}x{height} pixels; expected {shape[1]}x{shape[0]} "
                                    "(width x height)")
            array = np.asarray(image, dtype=np.uint8)
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        if isinstance(exc, PairDataError):
            raise
        raise PairDataError(f"cannot read image {path}: {exc}".splitlines()[0]) from None
    return array


def load_pairs(folder: Path | str, shape: tuple[int, int, int] = IMAGE_SHAPE) -> PairedImages:
    """Load and validate a paired-image folder (see the module docstring)."""
    root = Path(folder)
    if not root.exists():
        raise PairFolderNotFound(f"paired-image folder {root} does not exist")
    if not root.is_dir():
        raise PairDataError(f"{root} is not a folder")
    sim_files = _image_files(root / "sim")
    real_files = _image_files(root / "real")
    if not sim_files and not real_files:
        raise PairDataError(f"{root} holds no image pairs (sim/ and real/ are empty)")
    only_sim = sorted(set(sim_files) - set(real_files))
    only_real = sorted(set(real_files) - set(sim_files))
    if only_sim or only_real:
        side, names = ("sim/", only_sim) if only_sim else ("real/", only_real)
        other = "real/" if only_sim else "sim/"
        shown = ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
        raise PairDataError(f"{root}: unpaired images, {len(names)} name(s) in {side} without a partner in "
                            f"{other}: {shown}")
    manifest: dict = {}
    manifest_path = root / MANIFEST_NAME
    if manifest_path.is_file():
        try:
            manifest = json.loads(manifest_path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise PairDataError(f"cannot read {manifest_path}: {exc}".splitlines()[0]) from None
        if not isinstance(manifest, dict):
            raise PairDataError(f"{manifest_path} must hold a JSON object")
    names = sorted(sim_files)
    sim = np.empty((len(names), *shape), dtype=np.uint8)
    real = np.empty_like(sim)
    for i, name in enumerate(names):
        sim[i] = read_image(sim_files[name], shape)
        real[i] = read_image(real_files[name], shape)
    return PairedImages(names=names, sim=sim, real=real, manifest=manifest)
