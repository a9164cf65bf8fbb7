"""Every dual-system ``--algo`` × ``--ac`` pair trains a tiny run end to end through the shared trainer."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
import torch
from PIL import Image

from core.config import load_config
from core.dual.diagnostics_panel import smooth_skipping_nan
from core.runs.trainer import train

TINY = [
    "run.episodes=2", "run.eval_every=0", "run.eval_episodes=1", "run.checkpoint_every=0",
    "env.max_steps=8", "agent.learning_starts=4", "agent.batch_size=8", "agent.buffer_size=400",
    "net.conv_channels=4,4,4", "dual.latent_buffer_size=400",
    "dual.latent_batch_size=8", "dual.plan_steps=2",
]

DUAL_KEYS = ("dual/model_error", "dual/mb_decisions", "dual/mf_decisions", "dual/horizon", "dual/itm_nodes",
             "dual/imagined", "dual/intrinsic_reward", "dual/region_rint_mean", "dual/region_rint_std")


@pytest.mark.parametrize("ac", ["ddpg", "cacla", "td3", "sac"])
@pytest.mark.parametrize("algo", ["im2c", "i2a", "cmc", "la-imagination", "mve"])
def test_algo_trains_tiny_run_end_to_end(tmp_path, algo: str, ac: str) -> None:
    config = load_config("default", [f"run.algo={algo}", f"agent.ac={ac}", *TINY])
    summary = train(config, tmp_path / "run", command="test")
    assert summary["episodes"] == 2 and summary["steps"] >= 2
    assert summary["algo"] == algo and summary["ac"] == ac
    assert 0.0 <= summary["success_rate"] <= 1.0
    rows = list(csv.DictReader((tmp_path / "run" / "metrics.csv").open()))
    assert len(rows) == 2
    assert math.isfinite(float(rows[-1]["losses/critic"]))
    assert math.isfinite(float(rows[-1]["dual/model_error"]))
    if algo != "mve":
        for key in DUAL_KEYS:
            assert key in rows[-1], key
        decisions = sum(float(r["dual/mb_decisions"]) + float(r["dual/mf_decisions"]) for r in rows)
        assert decisions == summary["steps"]
    checkpoint = torch.load(tmp_path / "run" / "checkpoints" / "latest.pt", weights_only=True)
    assert "dual" in checkpoint["agent"]
    with Image.open(tmp_path / "run" / "learning_curve.png") as picture:
        assert picture.size == (700, 700)  # two panels: the learning curve and the dual diagnostics


def test_i2a_resume_continues_from_checkpoint(tmp_path) -> None:
    config = load_config("default", ["run.algo=i2a", *TINY])
    train(config, tmp_path / "run", command="test")
    config.run.episodes = 3
    summary = train(config, tmp_path / "run", resume=True, command="test")
    assert summary["episodes"] == 3
    rows = list(csv.DictReader((tmp_path / "run" / "metrics.csv").open()))
    assert [int(r["episode"]) for r in rows] == [1, 2, 3]


def test_panel_smoothing_skips_episodes_without_a_value() -> None:
    values = [np.nan, 2.0, np.nan, 4.0, 6.0]
    np.testing.assert_allclose(smooth_skipping_nan(values, 2), [np.nan, 2.0, 2.0, 4.0, 5.0])


def test_bench_train_times_dual_algos() -> None:
    from bench.train_speed import measure

    result = measure(algos=("i2a", "mve"), steps=10, warmup=10, rounds=1, buffer=500, threads=1)
    assert result["i2a"]["ms_per_step"] > 0 and result["mve"]["ms_per_step"] > 0
    with pytest.raises(ValueError, match="unknown bench method"):
        measure(algos=("i3a",), steps=10, warmup=10, rounds=1)
