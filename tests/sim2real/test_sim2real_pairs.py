"""Paired images: generation layout and determinism; loading validation (every bad input, nothing written)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from PIL import Image

from core.envs import CameraShift
from sim2real import PairDataError, PairFolderNotFound, generate_pairs, load_pairs, read_camera_shift


@pytest.fixture(scope="module")
def pairs_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("pairs") / "set"
    generate_pairs(n=6, out=out, seed=3)
    return out


def copy_of(pairs_dir, tmp_path):
    target = tmp_path / "copy"
    shutil.copytree(pairs_dir, target)
    return target


def test_generation_writes_the_layout_and_a_manifest(pairs_dir):
    sims = sorted(p.name for p in (pairs_dir / "sim").iterdir())
    reals = sorted(p.name for p in (pairs_dir / "real").iterdir())
    assert sims == reals == [f"{i:06d}.png" for i in range(6)]
    manifest = json.loads((pairs_dir / "manifest.json").read_text())
    assert manifest["format"] == "dualsys-pairs/1" and manifest["count"] == 6 and manifest["seed"] == 3
    assert [p["name"] for p in manifest["pairs"]] == [f"{i:06d}" for i in range(6)]
    assert manifest["camera_shift"] == json.loads(json.dumps(CameraShift().to_dict()))
    shoulders = [p["shoulder_deg"] for p in manifest["pairs"]]
    assert all(33.0 <= q <= 93.0 for q in shoulders) and len(set(shoulders)) == 6
    loaded = load_pairs(pairs_dir)
    assert len(loaded) == 6 and loaded.sim.shape == loaded.real.shape == (6, 32, 64, 3)
    assert loaded.sim.dtype == np.uint8
    assert np.abs(loaded.sim.astype(int) - loaded.real.astype(int)).mean() > 3.0  # two different cameras


def test_same_seed_same_images_and_the_shift_file_is_used(pairs_dir, tmp_path):
    again = tmp_path / "again"
    generate_pairs(n=6, out=again, seed=3)
    first, second = load_pairs(pairs_dir), load_pairs(again)
    assert np.array_equal(first.sim, second.sim) and np.array_equal(first.real, second.real)
    shift_file = tmp_path / "shift.yaml"
    shift_file.write_text("colour_gain: [1.3, 0.8, 0.7]\nbrightness: 25\nnoise_std: 0\n")
    shift = read_camera_shift(shift_file)
    assert shift.colour_gain == (1.3, 0.8, 0.7) and shift.noise_std == 0
    shifted = load_pairs(generate_pairs(n=6, out=tmp_path / "shifted", seed=3, camera_shift=shift).out)
    assert np.array_equal(shifted.sim, first.sim) and not np.array_equal(shifted.real, first.real)


def test_generation_refuses_a_non_empty_folder_and_bad_counts(pairs_dir, tmp_path):
    before = sorted(p.name for p in (pairs_dir / "sim").iterdir())
    with pytest.raises(PairDataError, match="not an empty folder"):
        generate_pairs(n=2, out=pairs_dir)
    assert sorted(p.name for p in (pairs_dir / "sim").iterdir()) == before
    with pytest.raises(ValueError):
        generate_pairs(n=0, out=tmp_path / "zero")
    assert not (tmp_path / "zero").exists()
    (tmp_path / "empty").mkdir()
    generate_pairs(n=1, out=tmp_path / "empty")  # an empty folder is fine
    assert len(load_pairs(tmp_path / "empty")) == 1
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no staging left


def test_missing_and_empty_folders(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_pairs(tmp_path / "absent")
    with pytest.raises(PairFolderNotFound):
        load_pairs(tmp_path)  # exists but has no sim/ real/
    (tmp_path / "sim").mkdir()
    (tmp_path / "real").mkdir()
    with pytest.raises(PairDataError, match="no image pairs"):
        load_pairs(tmp_path)


def test_unpaired_names(pairs_dir, tmp_path):
    folder = copy_of(pairs_dir, tmp_path)
    (folder / "real" / "000002.png").unlink()
    (folder / "real" / "000004.png").rename(folder / "real" / "extra.png")
    with pytest.raises(PairDataError, match=r"unpaired images, 2 name\(s\) in sim/.*000002, 000004"):
        load_pairs(folder)


@pytest.mark.parametrize(("mode", "size", "fragment"), [
    ("RGB", (32, 32), "is 32x32 pixels; expected 64x32"),
    ("RGBA", (64, 32), "4 channel(s)"),
    ("L", (64, 32), "1 channel(s)"),
])
def test_wrong_size_or_channels_names_the_file(pairs_dir, tmp_path, mode, size, fragment):
    folder = copy_of(pairs_dir, tmp_path)
    Image.new(mode, size).save(folder / "real" / "000001.png")
    with pytest.raises(PairDataError, match=r"000001\.png") as error:
        load_pairs(folder)
    assert fragment in str(error.value) and "\n" not in str(error.value)


def test_unreadable_file_and_bad_manifest(pairs_dir, tmp_path):
    folder = copy_of(pairs_dir, tmp_path)
    (folder / "sim" / "000003.png").write_bytes(b"\x89PNG but not really")
    with pytest.raises(PairDataError, match=r"cannot read image .*sim/000003.png"):
        load_pairs(folder)
    folder = copy_of(pairs_dir, tmp_path / "second")
    (folder / "manifest.json").write_text("{not json")
    with pytest.raises(PairDataError, match=r"manifest\.json"):
        load_pairs(folder)


def test_user_pairs_without_a_manifest_load_and_other_files_are_ignored(tmp_path):
    rng = np.random.default_rng(0)
    for side in ("sim", "real"):
        (tmp_path / side).mkdir()
        for name in ("a", "b"):
            image = rng.integers(0, 256, (32, 64, 3), dtype=np.uint8)
            Image.fromarray(image).save(tmp_path / side / f"{name}.png")
    (tmp_path / "sim" / "notes.txt").write_text("ignored")
    loaded = load_pairs(tmp_path)
    assert loaded.names == ["a", "b"] and loaded.manifest == {}
    assert np.array_equal(loaded.sim[0], np.asarray(Image.open(tmp_path / "sim" / "a.png")))
