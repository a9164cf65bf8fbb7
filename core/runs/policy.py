"""Load a trained policy (encoder f_ω + actor μ) from a run directory or checkpoint file.

``load_policy(path)`` accepts a run directory (uses ``checkpoints/best.pt``, else ``checkpoints/latest.pt``)
or a ``.pt`` checkpoint written by the trainer. The networks are rebuilt from the checkpoint's ``net``
config and the env spec stored in the checkpoint (observation kind, shape, dtype, action bounds), and
loaded with ``torch.load(weights_only=True)``. ``Policy.act(obs[N, *obs_shape])`` returns
``actions[N, action_dim]`` in the env's units as float32 NumPy — the greedy deployment policy μ(f(s)) used
by export, eval and sim-to-real alignment (``Policy.network`` is the ``nn.Module`` they export or fine-tune).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import Config
from core.dual.readings import upgrade_stored
from core.envs.spec import EnvSpec
from core.modelfree.networks import (
    ActionBounds,
    Actor,
    ObservationEncoder,
    PolicyNetwork,
    make_actor,
    make_encoder,
)
from core.runs.methods import MODEL_FREE_ALGOS
from core.runs.run_dir import RunDirectory, load_checkpoint


def observation_batch(obs: np.ndarray, obs_shape: tuple[int, ...], obs_dtype: str = "uint8") -> np.ndarray:
    """Check and batch policy input: ``[N, *obs_shape]`` (or one ``obs_shape`` → ``[1, *obs_shape]``) of the
    policy's dtype: uint8 images exactly; vectors of any real dtype, converted to float32 (the networks')."""
    batch = np.asarray(obs)
    if obs_dtype == "uint8":
        if batch.dtype != np.uint8:
            raise ValueError(f"observations must be uint8 images, got {batch.dtype}")
    elif not (np.issubdtype(batch.dtype, np.floating) or np.issubdtype(batch.dtype, np.integer)):
        raise ValueError(f"observations must be real-valued vectors, got {batch.dtype}")
    if batch.ndim == len(obs_shape):
        batch = batch[None]
    if batch.shape[1:] != tuple(obs_shape):
        raise ValueError(
            f"observations must have shape [N, {', '.join(map(str, obs_shape))}], got {list(batch.shape)}"
        )
    return np.ascontiguousarray(batch if obs_dtype == "uint8" else batch.astype(np.float32))


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
    def encoder(self) -> ObservationEncoder:
        return self.network.encoder

    @property
    def actor(self) -> Actor:
        return self.network.actor

    @property
    def spec(self) -> EnvSpec:
        """The observation and action spaces the policy was trained on."""
        return self.metadata["spec"]

    @property
    def obs_shape(self) -> tuple[int, ...]:
        return tuple(self.spec.obs_shape)

    @property
    def action_dim(self) -> int:
        return self.actor.action_dim

    @torch.no_grad()
    def act(self, obs: np.ndarray) -> np.ndarray:
        """Greedy actions in the env's units for observations ``[N, *obs_shape]`` (or one → ``[1, A]``)."""
        batch = observation_batch(obs, self.obs_shape, self.spec.obs_dtype)
        self.network.eval()
        return self.network(torch.from_numpy(batch)).numpy().astype(np.float32)

    @torch.no_grad()
    def encode(self, obs: np.ndarray) -> np.ndarray:
        """Latents φ = f_ω(s) for observations ``[N, *obs_shape]``."""
        batch = observation_batch(obs, self.obs_shape, self.spec.obs_dtype)
        return self.encoder(self.encoder.prepare(torch.from_numpy(batch))).numpy()


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
    config = Config.from_dict(upgrade_stored(state["config"]))
    weights = state["policy"]
    actor_weights = dict(weights["actor"])
    actor_weights.pop("action_scale", None)  # checkpoints before normalised actions: always 1
    spec = EnvSpec.from_dict(
        {**state, "action_dim": state.get("action_dim", _output_size(actor_weights))}
    )
    ac = config.run.algo if config.run.algo in MODEL_FREE_ALGOS else config.agent.ac
    encoder = make_encoder(config.net, spec, ac)
    actor = make_actor(config.net, spec, ac, encoder.latent_dim)
    bounds = ActionBounds(*(torch.from_numpy(b) for b in spec.bounds()))
    encoder.load_state_dict(weights["encoder"])
    actor.load_state_dict(actor_weights)
    if "bounds" in weights:
        bounds.load_state_dict(weights["bounds"])
    network = PolicyNetwork(encoder, actor, bounds).eval()
    metadata = {
        "obs_shape": spec.obs_shape,
        "spec": spec,
        "counters": state.get("counters", {}),
        "eval": state.get("eval", {}),
    }
    return Policy(network=network, config=config, source=checkpoint_path, metadata=metadata)


def _output_size(actor_weights: dict[str, torch.Tensor]) -> int:
    """The action size of an actor's state dict (its last linear layer's outputs)."""
    biases = [value for key, value in actor_weights.items() if key.endswith(".bias")]
    return int(biases[-1].shape[0])
