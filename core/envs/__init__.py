"""NicoGrasp, the paper's vision-based grasping task, and its camera domains; ThreeRegions, the controlled
problem of the intrinsic-reward check; NoisyTV, ThreeRegions with a fixed start and coverage over training.

Importing this package registers the gymnasium ids ``dualsys/NicoGrasp-v0``, ``dualsys/ThreeRegions-v0`` and
``dualsys/NoisyTV-v0``.
It does not import PyBullet, which prints its build banner when imported: ``NicoGraspEnv`` and
``PhysicsSettings`` are imported on first use (``core.envs.NicoGraspEnv``, ``from core.envs import ...``,
or gymnasium building the id), so a command that never builds NicoGrasp prints no banner.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import gymnasium as gym

from core.envs.camera import CameraPose, CameraShift, Lighting
from core.envs.oracle import oracle_action, run_oracle
from core.envs.robot_description import ArmGeometry
from core.envs.three_regions import ThreeRegionsEnv

ENV_ID = "dualsys/NicoGrasp-v0"
THREE_REGIONS_ID = "dualsys/ThreeRegions-v0"
NOISY_TV_ID = "dualsys/NoisyTV-v0"

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="core.envs.nico_grasp:NicoGraspEnv", max_episode_steps=None)
if THREE_REGIONS_ID not in gym.registry:
    gym.register(id=THREE_REGIONS_ID, entry_point="core.envs.three_regions:ThreeRegionsEnv",
                 max_episode_steps=None)
if NOISY_TV_ID not in gym.registry:
    gym.register(id=NOISY_TV_ID, entry_point="core.envs.noisy_tv:NoisyTVEnv", max_episode_steps=None)

if TYPE_CHECKING:
    from core.envs.nico_grasp import NicoGraspEnv, PhysicsSettings
    from core.envs.noisy_tv import NoisyTVEnv

_NICO_GRASP_NAMES = ("NicoGraspEnv", "PhysicsSettings")


def __getattr__(name: str) -> Any:
    """``NicoGraspEnv`` and ``PhysicsSettings`` from `core.envs.nico_grasp`, imported (with PyBullet) on
    first use; ``NoisyTVEnv`` from `core.envs.noisy_tv`."""
    if name in _NICO_GRASP_NAMES:
        import core.envs.nico_grasp as nico_grasp

        return getattr(nico_grasp, name)
    if name == "NoisyTVEnv":  # on first use, so `python -m core.envs.noisy_tv` runs a module not yet imported
        import core.envs.noisy_tv as noisy_tv

        return noisy_tv.NoisyTVEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "ENV_ID",
    "NOISY_TV_ID",
    "THREE_REGIONS_ID",
    "ArmGeometry",
    "CameraPose",
    "CameraShift",
    "Lighting",
    "NicoGraspEnv",
    "NoisyTVEnv",
    "PhysicsSettings",
    "ThreeRegionsEnv",
    "oracle_action",
    "run_oracle",
]
