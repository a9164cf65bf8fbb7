"""Camera images of random NicoGrasp states, from the simulator's camera and the real-camera stand-in.

The states are those a grasp trial visits: the glass at a random graspable position (the env's own sampler:
angle and radial jitter) and the shoulder anywhere in its window, the hand open. Each state is rendered by
both cameras (``env.unwrapped.render_observation("sim" | "real")``), so the two images of one state are a
*pair* (same joint configuration, same glass position) as Section 4.2's sim-to-real alignment needs. The
ONNX export's parity check uses the same images as "environment images".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from core.envs import CameraShift, NicoGraspEnv


@dataclass(frozen=True)
class PairedStates:
    """``n`` states rendered by both cameras."""

    sim: np.ndarray
    """uint8 ``[n, 32, 64, 3]`` from the simulator's camera."""
    real: np.ndarray
    """uint8 ``[n, 32, 64, 3]`` from the real-camera stand-in."""
    shoulder_deg: np.ndarray
    """``[n]`` shoulder angle of each state."""
    glass_pos: np.ndarray
    """``[n, 3]`` glass centre of each state (m)."""


def render_paired_states(
    n: int,
    *,
    seed: int = 0,
    camera_shift: CameraShift | None = None,
    on_image: Callable[[int], None] | None = None,
) -> PairedStates:
    """Render ``n`` random states with both cameras (deterministic in ``seed`` and ``camera_shift``)."""
    if n < 1:
        raise ValueError(f"the number of images must be >= 1, got {n}")
    env = NicoGraspEnv(camera_shift=camera_shift)
    try:
        rng = np.random.default_rng(seed)
        low, high = (math.degrees(v) for v in env.window_rad)
        shoulders = rng.uniform(low, high, size=n)
        height, width, channels = env.observation_space.shape
        sim = np.empty((n, height, width, channels), dtype=np.uint8)
        real = np.empty_like(sim)
        glass = np.empty((n, 3), dtype=np.float64)
        env.reset(seed=seed)  # one seeded reset; the following resets draw glass positions from it
        for i, shoulder in enumerate(shoulders):
            _, info = env.reset(options={"shoulder_deg": float(shoulder)})
            sim[i] = env.render_observation("sim")
            real[i] = env.render_observation("real")
            glass[i] = info["glass_pos"]
            if on_image is not None:
                on_image(i + 1)
        return PairedStates(sim=sim, real=real, shoulder_deg=shoulders, glass_pos=glass)
    finally:
        env.close()


def render_env_images(n: int, *, seed: int = 0, camera_shift: CameraShift | None = None) -> np.ndarray:
    """``n`` environment images, half from each camera (sim first), uint8 ``[n, 32, 64, 3]``."""
    states = render_paired_states(max(1, (n + 1) // 2), seed=seed, camera_shift=camera_shift)
    return np.concatenate([states.sim, states.real])[:n]
