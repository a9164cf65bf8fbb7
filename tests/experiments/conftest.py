"""Tiny experiment files for the experiment tests (CPU, seconds per cell)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

TINY_OVERRIDES: dict[str, Any] = {
    "net.conv_channels": [4, 4],
    "net.latent_dim": 8,
    "net.critic_hidden": 8,
    "net.actor_hidden": 8,
    "env.max_steps": 5,
    "agent.batch_size": 8,
    "agent.buffer_size": 400,
    "agent.learning_starts": 10,
    "dual.latent_buffer_size": 400,
    "run.checkpoint_every": 2,
}


def tiny_experiment_data(**changes: Any) -> dict[str, Any]:
    """A 2 methods × 1 reward × 2 seeds grid of ~100 env steps per cell (``changes`` replace keys)."""
    data: dict[str, Any] = {
        "name": "tiny",
        "profile": "default",
        "level": "released",
        "rewards": ["dense"],
        "seeds": 2,
        "steps": 100,
        "eval_every": 10,
        "eval_episodes": 2,
        "overrides": dict(TINY_OVERRIDES),
        "methods": [
            {"label": "DDPG", "algo": "ddpg"},
            {"label": "DDPG+IM2C", "algo": "im2c", "ac": "ddpg"},
        ],
    }
    data.update(changes)
    return data


@pytest.fixture()
def write_experiment(tmp_path: Path):
    """``write_experiment(**changes) -> Path`` of a YAML experiment file in tmp_path."""

    def write(name: str = "tiny.yaml", **changes: Any) -> Path:
        path = tmp_path / name
        path.write_text(yaml.safe_dump(tiny_experiment_data(**changes), sort_keys=False))
        return path

    return write
