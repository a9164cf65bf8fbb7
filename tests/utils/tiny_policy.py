"""Factory: a real (tiny) trained run directory from ``core.runs.trainer.train``, for deployment tests.

The networks keep the default architecture's shape at a smaller width (so the encoder's latents are not
degenerate and alignment has something to move); the env and learner settings are tiny so a run takes a
few seconds on one CPU thread.
"""

from __future__ import annotations

from pathlib import Path

from core.config import load_config
from core.runs.trainer import train

TINY_DEPLOY = [
    "net.conv_channels=8,8,8", "net.latent_dim=16", "net.critic_hidden=8", "net.actor_hidden=8",
    "env.max_steps=6", "agent.batch_size=8", "agent.buffer_size=200", "agent.learning_starts=8",
    "run.eval_every=0", "run.eval_episodes=1", "run.checkpoint_every=0", "run.num_threads=1",
    "run.episodes=2",
]


def train_tiny_policy(run_dir: Path, *, hand: str = "auto", seed: int = 0) -> Path:
    """Train 2 tiny episodes into ``run_dir`` (``checkpoints/best.pt`` holds encoder + actor)."""
    config = load_config("default", [*TINY_DEPLOY, f"env.hand={hand}", f"run.seed={seed}"])
    train(config, run_dir, command="pytest tiny deploy policy")
    return run_dir
