"""`dualsys env ...` end to end, through the installed console script."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from PIL import Image

DUALSYS = [sys.executable, "-m", "dualsys_cli.main"]


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*DUALSYS, *args], capture_output=True, text=True, timeout=120)


def test_env_check_prints_only_json():
    result = run("env", "check", "--episodes", "5", "--json")
    assert result.returncode == 0, result.stderr
    payload = json.loads(result.stdout)  # the whole stdout is one JSON document
    assert payload["episodes"] == 5
    assert payload["oracle_success_rate"] >= 0.8


def test_env_show_writes_a_readable_picture(tmp_path: Path):
    out = tmp_path / "scene.png"
    result = run("env", "show", "--out", str(out))
    assert result.returncode == 0, result.stderr
    picture = Image.open(out)
    assert picture.width == 3 * 512 and picture.height > 256


def test_bad_option_value_is_one_line_exit_2():
    result = run("env", "check", "--hand", "tentacle", "--episodes", "1")
    assert result.returncode == 2
    lines = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert lines == ["error: unknown hand 'tentacle'; choose one of: auto, learned"]
    assert "Traceback" not in result.stderr


def test_commands_that_build_no_nicograsp_print_no_pybullet_banner():
    """PyBullet prints `pybullet build time: ...` when imported; only building NicoGrasp imports it
    (core/envs/__init__.py), so these commands print no banner."""
    root = Path(__file__).resolve().parents[2]
    imported = subprocess.run(
        [sys.executable, "-c", "import pybullet"], capture_output=True, text=True, timeout=120, cwd=root
    )
    assert "pybullet build time" in imported.stdout + imported.stderr  # the banner this test looks for
    for args, returncode in ((["--help"], 0), (["env", "list"], 0), (["train", "--env", "Foo-v9"], 2)):
        result = subprocess.run([*DUALSYS, *args], capture_output=True, text=True, timeout=120, cwd=root)
        assert result.returncode == returncode, (args, result.stderr)
        assert "pybullet build time" not in result.stdout + result.stderr, (args, result.stderr)
