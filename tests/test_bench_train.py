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


def test_profile_and_settings_shape_our_methods():
    from bench.train_speed import _config

    config = _config(
        "im2c", None, 500, "MountainCarContinuous-v0", "vector", ("agent.ac=sac", "dual.planner=progress")
    )
    assert (config.agent.ac, config.dual.planner, config.agent.buffer_size) == ("sac", "progress", 500)
    # The user's settings come after the bench's own keys, so they win.
    assert _config("sac", None, 500, None, "vector", ("agent.buffer_size=700",)).agent.buffer_size == 700


def test_measure_times_the_progress_planner_on_a_vector_task():
    result = measure(
        algos=("im2c",),
        batch=8,
        steps=5,
        warmup=10,
        rounds=1,
        buffer=500,
        env="MountainCarContinuous-v0",
        profile="vector",
        settings=("agent.ac=sac", "dual.planner=progress"),
    )
    assert result["im2c"]["ms_per_step"] > 0
    assert (result["profile"], result["settings"]) == ("vector", ["agent.ac=sac", "dual.planner=progress"])
