"""``scripts/dual_controller_eval.py``: a finished dual run, rebuilt from its final checkpoint, evaluates its
actor exactly as the run's own final evaluation did, and its controller (arbitration, planning) on the same
starts."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

from core.config import load_config
from core.runs.trainer import train

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "dual_controller_eval.py"


def _script():
    spec = importlib.util.spec_from_file_location("dual_controller_eval", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_rebuilt_actor_reproduces_the_runs_final_greedy_return(tmp_path):
    config = load_config("vector", [
        "env.id=Pendulum-v1", "run.algo=im2c", "agent.ac=sac", "run.episodes=2", "run.eval_every=0",
        "run.eval_episodes=2", "agent.learning_starts=50", "agent.batch_size=16", "dual.plan_steps=2",
    ])
    summary = train(config, tmp_path / "run", command="test")
    result = _script().evaluate_run(tmp_path / "run", episodes=2)
    assert result["actor"] == pytest.approx(summary["eval_return"], abs=1e-6)
    assert result["run_eval_return"] == summary["eval_return"] and result["reproduces_run"]
    assert math.isfinite(result["controller"])


def test_a_model_free_run_is_refused(tmp_path):
    config = load_config(
        "vector", ["env.id=Pendulum-v1", "run.algo=sac", "run.episodes=1", "run.eval_episodes=1"]
    )
    train(config, tmp_path / "run", command="test")
    with pytest.raises(SystemExit, match="has no dual system"):
        _script().evaluate_run(tmp_path / "run", episodes=1)
