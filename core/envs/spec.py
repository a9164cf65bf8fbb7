"""What an agent needs to know of its environment: the observation's kind, shape and dtype, and the actions.

Agents act in a normalised action space: every action the actor, the exploration noise, the planner, the
local world models and the replay see lies in [-1, 1]^d. The environment is wrapped so that it receives
``low + (a + 1) / 2 · (high − low)`` (gymnasium's ``RescaleAction``; skipped where the bounds already are
±1, as on NicoGrasp), and the deployable policy carries the same map in its last layer, so an exported
policy answers in the env's own units (``core.modelfree.networks.ActionBounds``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

ObservationKind = Literal["image", "vector"]


@dataclass(frozen=True)
class EnvSpec:
    """The observation and action spaces as the agent sees them (after ``core.envs.gym_env``'s wrappers)."""

    obs_shape: tuple[int, ...]
    """``(H, W, C)`` for images, ``(D,)`` for vectors."""
    action_dim: int
    obs_kind: ObservationKind = "image"
    obs_dtype: str = "uint8"
    """The dtype observations are stored in (the space's own: no lossy cast)."""
    obs_low: tuple[float, ...] | None = None
    """Finite per-dimension bounds of a vector observation (used to scale it to [-1, 1]); None: unbounded."""
    obs_high: tuple[float, ...] | None = None
    action_low: tuple[float, ...] = field(default=())
    """The env's own action bounds per dimension (the agent's [-1, 1] maps onto them); () means ±1."""
    action_high: tuple[float, ...] = field(default=())

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The env's action bounds as float32 arrays ``[action_dim]`` (±1 where none were given)."""
        low = np.asarray(self.action_low or (-1.0,) * self.action_dim, dtype=np.float32)
        high = np.asarray(self.action_high or (1.0,) * self.action_dim, dtype=np.float32)
        return low, high

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON types, stored in checkpoints so a policy can be rebuilt without its env."""
        return {
            "obs_shape": list(self.obs_shape),
            "action_dim": self.action_dim,
            "obs_kind": self.obs_kind,
            "obs_dtype": self.obs_dtype,
            "obs_low": None if self.obs_low is None else list(self.obs_low),
            "obs_high": None if self.obs_high is None else list(self.obs_high),
            "action_low": list(self.action_low),
            "action_high": list(self.action_high),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EnvSpec:
        """The inverse of :meth:`to_dict`; a checkpoint written before vector support is a NicoGrasp image."""
        low, high = data.get("obs_low"), data.get("obs_high")
        return cls(
            obs_shape=tuple(int(v) for v in data.get("obs_shape", (32, 64, 3))),
            action_dim=int(data["action_dim"]),
            obs_kind=data.get("obs_kind", "image"),
            obs_dtype=str(data.get("obs_dtype", "uint8")),
            obs_low=None if low is None else tuple(float(v) for v in low),
            obs_high=None if high is None else tuple(float(v) for v in high),
            action_low=tuple(float(v) for v in data.get("action_low", ())),
            action_high=tuple(float(v) for v in data.get("action_high", ())),
        )
