"""NicoGrasp, the paper's vision-based grasping task, and its camera domains.

Importing this package registers the gymnasium id ``dualsys/NicoGrasp-v0``.
"""

from __future__ import annotations

import gymnasium as gym

from core.envs.camera import CameraPose, CameraShift, Lighting
from core.envs.nico_grasp import NicoGraspEnv, PhysicsSettings
from core.envs.oracle import oracle_action, run_oracle
from core.envs.robot_description import ArmGeometry

ENV_ID = "dualsys/NicoGrasp-v0"

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="core.envs.nico_grasp:NicoGraspEnv", max_episode_steps=None)

__all__ = [
    "ENV_ID",
    "ArmGeometry",
    "CameraPose",
    "CameraShift",
    "Lighting",
    "NicoGraspEnv",
    "PhysicsSettings",
    "oracle_action",
    "run_oracle",
]
