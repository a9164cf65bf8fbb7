"""`bench/train_speed.py` runs and reports its contract shape (figures are never asserted)."""

from __future__ import annotations

import pytest

from bench.train_speed import measure


def test_measure_reports_ms_per_step_and_batch_per_method():
    result = measure(algos=("ddpg",), batch=8, steps=5, warmup=10, rounds=1, buffer=500)
    assert set(result["ddpg"]) >= {"ms_per_step", "batch"}
    assert result["ddpg"]["batch"] == 8 and result["ddpg"]["ms_per_step"] > 0


def test_sb3_peer_runs_when_installed():
    pytest.importorskip("stable_baselines3")
    result = measure(algos=("sb3-ddpg",), batch=8, steps=5, warmup=10, rounds=1, buffer=500)
    assert result["sb3-ddpg"]["batch"] == 8


def test_unknown_method_is_a_value_error():
    with pytest.raises(ValueError, match="unknown bench method"):
        measure(algos=("ppo",))
