"""Portable runs (run.cpu_isa): the pinned variables, the host check, the refusal of a pinned run in an
unpinned process, the experiment runner's pinned workers, and a short pinned run whose metrics must equal a
stored reference made with the pin, bit for bit, on any x86-64 machine with AVX2 (x86-64-v3) of the
reference's CPU vendor (tests/runs/data/portable_avx2_reference.json: AMD; …_intel.json: Intel): the pin fixes
the instruction set, not each vendor's kernels (`cpu_isa.cpu_vendor`).

Remake the reference (only after a deliberate change of the numerics, saying so in the commit):
    DUALSYS_WRITE_REFERENCE=1 .venv/bin/pytest tests/runs/test_portable_runs.py -k reference
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from core.config import ConfigError
from core.runs import cpu_isa

REFERENCES = {
    "amd": Path(__file__).parent / "data" / "portable_avx2_reference.json",
    "intel": Path(__file__).parent / "data" / "portable_avx2_reference_intel.json",
}
"""The stored pinned run per CPU vendor."""
ROOT = Path(__file__).resolve().parents[2]
REFERENCE_ARGS = [
    "train", "--env", "Pendulum-v1", "--algo", "sac", "--steps", "400", "--seed", "3",
    "--set", "agent.learning_starts=200", "--set", "run.eval_every=0", "--set", "run.eval_episodes=1",
    "--set", "run.cpu_isa=avx2", "--json",
]
"""SAC on Pendulum-v1: 200 uniform warm-up steps, then 200 updates of the 256-256 networks at batch 256 (the
sizes where MKL's AVX2 and AVX-512 kernels round differently), and one greedy evaluation episode."""
COMPARED = (
    "episode", "global_step", "charts/episodic_return", "charts/start_value", "charts/discounted_return",
    "charts/alpha", "losses/critic", "losses/actor", "losses/alpha", "losses/td_target_mean", "eval/return",
)
"""metrics.csv's columns compared (not the timings; a column added later does not break the reference)."""

needs_avx2 = pytest.mark.skipif(
    cpu_isa.host_problem("avx2") is not None, reason=str(cpu_isa.host_problem("avx2"))
)


def test_pinned_environment_names_every_library():
    assert cpu_isa.pinned_environment("native") == {}
    avx2 = cpu_isa.pinned_environment("avx2")
    assert avx2["ATEN_CPU_CAPABILITY"] == "avx2" and avx2["MKL_CBWR"] == "AVX2"
    assert avx2["ONEDNN_MAX_CPU_ISA"] == "AVX2" and avx2["OPENBLAS_CORETYPE"] == "Haswell"
    assert set(avx2) <= set(cpu_isa.CPU_ISA_KEYS)
    # NumPy: everything it dispatches above x86-64-v3 is switched off, nothing at or below it
    disabled = set(avx2.get("NPY_DISABLE_CPU_FEATURES", "").split())
    assert not disabled & cpu_isa.PINS["avx2"].numpy_allowed
    assert cpu_isa.pinned_environment("sse42")["ATEN_CPU_CAPABILITY"] == "default"
    with pytest.raises(ConfigError, match=r"run\.cpu_isa"):
        cpu_isa.pinned_environment("avx9")


def test_a_host_without_the_instruction_set_is_refused_in_one_line(monkeypatch):
    assert cpu_isa.missing_flags("avx2", {"sse4_2", "avx"}, "x86_64")[:2] == ["avx2", "fma"]
    assert cpu_isa.missing_flags("avx2", set(cpu_isa.PINS["avx2"].flags), "x86_64") == []
    assert cpu_isa.missing_flags("avx2", set(), "aarch64") is None
    assert cpu_isa.missing_flags("native", set(), "aarch64") == []
    assert cpu_isa.cpu_flags("processor : 0\nflags\t\t: fpu avx2 fma\n") == {"fpu", "avx2", "fma"}
    monkeypatch.setattr(cpu_isa, "cpu_flags", lambda cpuinfo=None: {"sse4_2", "avx"})
    monkeypatch.setattr(cpu_isa.platform, "machine", lambda: "x86_64")
    with pytest.raises(ConfigError) as error:
        cpu_isa.check_host("avx2")
    message = str(error.value)
    assert "\n" not in message and "x86-64-v3" in message and "lacks avx2, fma" in message


def test_a_pinned_run_refuses_an_unpinned_process(monkeypatch, tmp_path):
    for key in cpu_isa.CPU_ISA_KEYS:
        monkeypatch.delenv(key, raising=False)
    monkeypatch.setattr(cpu_isa, "host_problem", lambda name: None)
    with pytest.raises(ConfigError, match="must be set before torch and NumPy start"):
        cpu_isa.check_process("avx2")
    # only the dualsys command re-executes itself; in any other process (here pytest's) it refuses
    with pytest.raises(ConfigError, match="must be set before torch and NumPy start"):
        cpu_isa.ensure_process("avx2", argv=[sys.argv[0], "train"])
    cpu_isa.ensure_process("native", argv=[sys.argv[0], "train"])
    assert cpu_isa.check_process("native")["cpu_isa"] == "native"


def _metrics(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open(newline="") as file:
        return [{k: row[k] for k in COMPARED if k in row} for row in csv.DictReader(file)]


@needs_avx2
@pytest.mark.timeout(300)
def test_a_short_pinned_run_reproduces_its_stored_reference(tmp_path):
    """Through the command itself: `python -m dualsys_cli.main train` re-executes with the pin."""
    reference_path = REFERENCES.get(cpu_isa.cpu_vendor())
    if reference_path is None:
        pytest.skip(f"no pinned reference for this CPU vendor ({cpu_isa.cpu_model()})")
    env = {k: v for k, v in os.environ.items() if k not in cpu_isa.CPU_ISA_KEYS}
    run_dir = tmp_path / "run"
    done = subprocess.run(
        [sys.executable, "-m", "dualsys_cli.main", *REFERENCE_ARGS, "--out", str(run_dir)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=280,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads((run_dir / "summary.json").read_text())
    assert (summary["cpu_isa"], summary["cpu_capability"]) == ("avx2", "AVX2")
    assert yaml.safe_load((run_dir / "config.yaml").read_text())["run"]["cpu_isa"] == "avx2"
    got = {"metrics": _metrics(run_dir), "eval_return": repr(summary["eval_return"])}
    if os.environ.get("DUALSYS_WRITE_REFERENCE") == "1":
        reference_path.write_text(
            json.dumps({"command": ["dualsys", *REFERENCE_ARGS], "cpu_model": summary["cpu_model"], **got},
                       indent=1) + "\n"
        )
    reference = json.loads(reference_path.read_text())
    assert got["metrics"] == reference["metrics"], "a pinned run drifted from its reference"
    assert got["eval_return"] == reference["eval_return"]
