"""Benchmark: NicoGrasp env steps per second under random actions, beside the bare-PyBullet floor.

The floor is measured in the same run: the same scene files loaded into a bare PyBullet client, and per
"step" exactly the work an env step cannot avoid — a shoulder motor command, `move_substeps` physics
steps and one 64×32 render with the same camera and light. `ratio` = env step cost / floor step cost
(goal ≤ 1.3). Resets and the Python bookkeeping count against the env.

Per task level (`level`): the env runs the level's scene and hand under uniform random actions, and the floor
moves the same arm in the same window from the same start. With the learned hand a random action closes the
hand half the time; those steps cost a grasp attempt's physics (close, verify move) in the env, so the floor
does the same bare physics for them (and, on a level with one attempt per episode, re-places the glass
after each), so that the ratio measures our overhead, not the level's rules.
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


def _env_rate(seconds: float, seed: int, level: str) -> float:
    env = NicoGraspEnv(level=level)
    rng = np.random.default_rng(seed)
    shape = env.action_space.shape
    env.reset(seed=seed)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, size=shape).astype(np.float32))
        steps += 1
        if terminated or truncated:
            env.reset()
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def _floor_rate(seconds: float, seed: int, level: str) -> float:
    env = NicoGraspEnv(level=level)  # only for its geometry, camera, physics constants and rules
    geometry, physics, light = env.geometry, env.physics, env.sim_lighting
    view, proj = env._views["sim"]
    window, start_angle, step_rad = env.window_rad, env.start_rad, env.step_rad
    learned_hand = env.hand == "learned"
    one_attempt = env.attempts_per_episode == 1
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
    fingers = [j for j in range(client.getNumJoints(robot)) if j != 0]

    def move(target: float) -> None:
        client.setJointMotorControl2(
            robot,
            0,
            pybullet.POSITION_CONTROL,
            targetPosition=target,
            force=physics.shoulder_force,
            maxVelocity=physics.shoulder_max_velocity,
            positionGain=physics.shoulder_position_gain,
        )
        for _ in range(physics.move_substeps):
            client.stepSimulation()

    q = start_angle
    client.resetJointState(robot, 0, q)
    steps, episode_steps, start = 0, 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        if episode_steps == FLOOR_EPISODE_STEPS:
            client.resetBasePositionAndOrientation(glass, placements[steps % len(placements)], (0, 0, 0, 1))
            q, episode_steps = start_angle, 0
            client.resetJointState(robot, 0, q)
        # The same arm motion an env step commands: a random shoulder change of up to 20° in the window.
        action = rng.uniform(-1, 1, size=2 if learned_hand else 1)
        q = float(np.clip(q + action[0] * step_rad, low, high))
        move(q)
        episode_steps += 1
        if learned_hand and action[1] > 0:
            # A grasp attempt's bare physics: close the fingers, move back to verify, open them again.
            client.setJointMotorControlArray(
                robot,
                fingers,
                pybullet.POSITION_CONTROL,
                targetPositions=[physics.finger_close_rad] * len(fingers),
            )
            for _ in range(physics.hand_substeps):
                client.stepSimulation()
            move(float(np.clip(q - step_rad, low, high)))
            client.setJointMotorControlArray(
                robot, fingers, pybullet.POSITION_CONTROL, targetPositions=[0.0] * len(fingers)
            )
            if one_attempt:
                episode_steps = FLOOR_EPISODE_STEPS
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


def measure(seconds: float = 6.0, seed: int = 0, rounds: int = 6, level: str = "released") -> dict:
    """Alternate short env and floor measurements so machine noise hits both alike; report medians."""
    env_rates, floor_rates = [], []
    for _ in range(rounds):
        env_rates.append(_env_rate(seconds / (2 * rounds), seed, level))
        floor_rates.append(_floor_rate(seconds / (2 * rounds), seed, level))
    ratios = np.asarray(floor_rates) / np.asarray(env_rates)
    return {
        "level": level,
        "env_steps_per_s": round(float(np.median(env_rates)), 1),
        "floor_steps_per_s": round(float(np.median(floor_rates)), 1),
        "ratio": round(float(np.median(ratios)), 3),
        "rounds": rounds,
    }
