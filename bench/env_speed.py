"""Benchmark: NicoGrasp env steps per second under random actions, beside the bare-PyBullet floor.

The floor is measured in the same run: the same scene files loaded into a bare PyBullet client, and per
"step" exactly the work an env step cannot avoid — a shoulder motor command, `move_substeps` physics
steps and one 64×32 render with the same camera and light. `ratio` = env step cost / floor step cost
(goal ≤ 1.3). Resets, grasp attempts (extra physics for closing and verifying) and the Python bookkeeping
all count against the env.
"""

from __future__ import annotations

import time

import numpy as np
import pybullet

from core.envs.camera import OBS_HEIGHT, OBS_WIDTH
from core.envs.nico_grasp import NicoGraspEnv
from core.envs.quiet_bullet import quiet_client
from core.envs.scene_files import scene_file

FLOOR_EPISODE_STEPS = 16
"""The floor re-places the glass upright this often: the mean episode length under random actions."""


def _env_rate(seconds: float, seed: int) -> float:
    env = NicoGraspEnv()
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, size=1).astype(np.float32))
        steps += 1
        if terminated or truncated:
            env.reset()
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def _floor_rate(seconds: float, seed: int) -> float:
    env = NicoGraspEnv()  # only for its geometry, camera and physics constants
    geometry, physics, light = env.geometry, env.physics, env.sim_lighting
    view, proj = env._views["sim"]
    window = env.window_rad
    rng = np.random.default_rng(seed)
    # Glass placements as the env makes them: upright on the hand's arc, re-placed every "episode".
    placements = [env._glass_position_for(*row) for row in env._sample_positions(rng, 64)]
    env.close()
    client = quiet_client()
    client.setGravity(0, 0, -9.81)
    client.setTimeStep(physics.time_step)
    client.loadURDF(scene_file("table", geometry), useFixedBase=True)
    robot = client.loadURDF(scene_file("robot", geometry), useFixedBase=True)
    glass = client.loadURDF(scene_file("glass", geometry), basePosition=placements[0])
    low, high = window
    client.resetJointState(robot, 0, low)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        if steps % FLOOR_EPISODE_STEPS == 0:
            client.resetBasePositionAndOrientation(glass, placements[steps % len(placements)], (0, 0, 0, 1))
            client.resetJointState(robot, 0, low)
        # The same arm motion an env step commands: a random shoulder target in the window.
        client.setJointMotorControl2(
            robot,
            0,
            pybullet.POSITION_CONTROL,
            targetPosition=float(rng.uniform(low, high)),
            force=physics.shoulder_force,
            maxVelocity=physics.shoulder_max_velocity,
            positionGain=physics.shoulder_position_gain,
        )
        for _ in range(physics.move_substeps):
            client.stepSimulation()
        client.getCameraImage(
            OBS_WIDTH,
            OBS_HEIGHT,
            view,
            proj,
            lightDirection=light.direction,
            shadow=0,
            renderer=pybullet.ER_TINY_RENDERER,
            flags=pybullet.ER_NO_SEGMENTATION_MASK,
        )
        steps += 1
    rate = steps / (time.perf_counter() - start)
    client.disconnect()
    return rate


def measure(seconds: float = 6.0, seed: int = 0, rounds: int = 6) -> dict:
    """Alternate short env and floor measurements so machine noise hits both alike; report medians."""
    env_rates, floor_rates = [], []
    for _ in range(rounds):
        env_rates.append(_env_rate(seconds / (2 * rounds), seed))
        floor_rates.append(_floor_rate(seconds / (2 * rounds), seed))
    ratios = np.asarray(floor_rates) / np.asarray(env_rates)
    return {
        "env_steps_per_s": round(float(np.median(env_rates)), 1),
        "floor_steps_per_s": round(float(np.median(floor_rates)), 1),
        "ratio": round(float(np.median(ratios)), 3),
        "rounds": rounds,
    }
