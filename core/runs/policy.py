"""Load a trained policy (encoder f_ω + actor μ) from a run directory or checkpoint file.

``load_policy(path)`` accepts a run directory (uses ``checkpoints/best.pt``, else ``checkpoints/latest.pt``)
or a ``.pt`` checkpoint written by the trainer. The networks are rebuilt from the checkpoint's ``net``
config and loaded with ``torch.load(weights_only=True)``. ``Policy.act(obs_uint8[N, 32, 64, 3])`` returns
``actions[N, action_dim]`` as float32 NumPy — the greedy deployment policy μ(f(s)) used by export, eval
and sim-to-real alignment (``Policy.network`` is the ``nn.Module`` they export or fine-tune).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import Config
from core.modelfree.networks import Actor, Encoder, PolicyNetwork
from core.runs.run_dir import RunDirectory, load_checkpoint


def observation_batch(obs: np.ndarray, obs_shape: tuple[int, ...]) -> np.ndarray:
    """Check and batch policy input: uint8 ``[N, H, W, 3]`` (or one ``[H, W, 3]`` → ``[1, H, W, 3]``)."""
    batch = np.asarray(obs)
    if batch.dtype != np.uint8:
        raise ValueError(f"observations must be uint8 images, got {batch.dtype}")
    if batch.ndim == 3:
        batch = batch[None]
    if batch.shape[1:] != tuple(obs_shape):
        raise ValueError(
            f"observations must have shape [N, {', '.join(map(str, obs_shape))}], got {list(batch.shape)}"
        )
    return np.ascontiguousarray(batch)


class PolicyLoadError(ValueError):
    """The path holds no loadable dualsys policy."""


@dataclass
class Policy:
    """A deployable policy: the encoder + actor network and the config it was trained with."""

    network: PolicyNetwork
    config: Config
    source: Path
    metadata: dict[str, Any]

    @property
    def encoder(self) -> Encoder:
        return self.network.encoder

    @property
    def actor(self) -> Actor:
        return self.network.actor

    @property
    def obs_shape(self) -> tuple[int, int, int]:
        return tuple(self.metadata["obs_shape"])  # type: ignore[return-value]

    @property
    def action_dim(self) -> int:
        return int(self.actor.action_scale.shape[0])

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Greedy actions for uint8 observations ``[N, H, W, 3]`` (or one ``[H, W, 3]`` → ``[1, A]``)."""
        batch = observation_batch(obs, self.obs_shape)
        self.network.eval()
        return self.network(torch.from_numpy(batch)).numpy().astype(np.float32)

    @torch.no_grad()
    def encode(self, obs: np.ndarray) -> np.ndarray:
        """Latents φ = f_ω(s) for uint8 observations ``[N, H, W, 3]``."""
        from core.modelfree.networks import to_float_chw

        return self.encoder(to_float_chw(torch.from_numpy(np.ascontiguousarray(obs)))).numpy()


def resolve_checkpoint(path: Path | str) -> Path:
    """A run directory → its best (else latest) checkpoint; a file → itself."""
    path = Path(path)
    if path.is_dir():
        run = RunDirectory(path)
        for candidate in (run.best_path, run.latest_path):
            if candidate.is_file():
                return candidate
        raise PolicyLoadError(f"no checkpoint in run directory {path} (expected checkpoints/best.pt)")
    if not path.is_file():
        raise PolicyLoadError(f"policy path not found: {path}")
    return path


def load_policy(path: Path | str) -> Policy:
    """Rebuild encoder + actor from a run directory or checkpoint file (see the module docstring)."""
    checkpoint_path = resolve_checkpoint(path)
    try:
        state = load_checkpoint(checkpoint_path)
    except (ValueError, RuntimeError, EOFError, OSError) as exc:
        raise PolicyLoadError(f"cannot load policy from {checkpoint_path}: {exc}".splitlines()[0]) from exc
    if "policy" not in state:
        raise PolicyLoadError(f"{checkpoint_path} holds no policy weights")
    config = Config.from_dict(state["config"])
    weights = state["policy"]
    action_dim = int(weights["actor"]["action_scale"].shape[0])
    obs_shape = tuple(int(v) for v in state.get("obs_shape", (32, 64, 3)))
    encoder = Encoder(config.net, obs_shape)  # type: ignore[arg-type]
    actor = Actor(config.net, action_dim)
    encoder.load_state_dict(weights["encoder"])
    actor.load_state_dict(weights["actor"])
    network = PolicyNetwork(encoder, actor).eval()
    metadata = {"obs_shape": obs_shape, "counters": state.get("counters", {}), "eval": state.get("eval", {})}
    return Policy(network=network, config=config, source=checkpoint_path, metadata=metadata)
