"""Portable grids (run.cpu_isa, docs/experiments.md "Portable runs"): the experiment runner starts each cell's
worker with its pin, refuses a host that lacks the instruction set before any cell starts, and every new
experiment file pins its kernels (the files that existed before the option keep what their archives are)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from core.experiments import load_experiment, run_experiment
from core.experiments.spec import ExperimentError
from core.runs import cpu_isa

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"

UNPINNED_GRIDS: frozenset[str] = frozenset({
    "cartpole-swingup-sparse",
    "fig10",
    "fig11",
    "hard-dense",
    "hard-sparse-ablations",
    "hard-sparse-long-im2c-mf",
    "hard-sparse-long",
    "hard-sparse-study2",
    "hard-sparse",
    "mountaincar-controls",
    "mountaincar-ddpg-parity",
    "mountaincar-dual-seeds",
    "mountaincar-early-flag",
    "mountaincar-learners-tuning",
    "mountaincar-orderings",
    "mountaincar-repairs",
    "mountaincar-tuning-paper",
    "mountaincar-tuning",
    "mountaincar",
    "paper-sparse",
    "pendulum-ddpg-diagnosis",
    "pendulum-defaults",
    "pendulum-parity",
    "pendulum-td3-parity",
    "reacher-hard-dual-seeds",
    "reacher-hard-sac-parity",
    "reacher-hard-sac-seeds",
    "reacher-hard",
    "released-sparse",
    "smoke",
    "study3-cartpole-swingup-sparse",
    "study3-hard-sparse",
    "study3-mountaincar",
    "study3-noisy-tv",
    "study3-reacher-hard",
    "study3-what-explores",
    "table1",
})
"""The experiment files written before run.cpu_isa: their archives ran native, and a pin added now would
refuse their cells as changed settings. Every other file must pin (a list that only ever shrinks)."""


def test_every_new_experiment_file_pins_its_kernels():
    unpinned = []
    for path in sorted(EXPERIMENTS.glob("*.yaml")):
        if path.stem in UNPINNED_GRIDS:
            continue
        data = yaml.safe_load(path.read_text()) or {}
        if (data.get("overrides") or {}).get("run.cpu_isa") not in ("avx2", "sse42"):
            unpinned.append(path.name)
    assert not unpinned, f"new grids set overrides: {{run.cpu_isa: avx2}} (docs/experiments.md): {unpinned}"


def _grid() -> dict:
    return {
        "name": "pins",
        "profile": "vector",
        "env": "Pendulum-v1",
        "seeds": [0],
        "steps": 200,
        "eval_every": 0,
        "eval_episodes": 1,
        "overrides": {"agent.batch_size": 8, "agent.learning_starts": 100, "net.mlp_hidden": [8, 8]},
        "methods": [
            {"label": "pinned", "algo": "ddpg", "overrides": {"run.cpu_isa": "avx2"}},
            {"label": "native", "algo": "ddpg"},
        ],
    }


def test_a_host_without_the_pin_is_refused_before_any_cell_starts(tmp_path, monkeypatch):
    monkeypatch.setattr(cpu_isa, "cpu_flags", lambda cpuinfo=None: {"sse4_2"})
    monkeypatch.setattr(cpu_isa.platform, "machine", lambda: "x86_64")
    with pytest.raises(ExperimentError, match="needs a x86-64-v3 CPU"):
        run_experiment(load_experiment(_grid()), tmp_path)
    assert not (tmp_path / "pins").exists()


@pytest.mark.skipif(cpu_isa.host_problem("avx2") is not None, reason=str(cpu_isa.host_problem("avx2")))
@pytest.mark.timeout(1800)
def test_one_worker_runs_a_pinned_and_a_native_cell_each_in_its_own_process(tmp_path):
    result = run_experiment(load_experiment(_grid()), tmp_path, workers=1)
    assert result.complete, result.to_dict()
    assert result.workers["pinned/task/seed-0"] != result.workers["native/task/seed-0"]
    pinned = json.loads((tmp_path / "pins" / "pinned" / "task" / "seed-0" / "summary.json").read_text())
    native = json.loads((tmp_path / "pins" / "native" / "task" / "seed-0" / "summary.json").read_text())
    assert (pinned["cpu_isa"], pinned["cpu_capability"]) == ("avx2", "AVX2")
    assert native["cpu_isa"] == "native"
