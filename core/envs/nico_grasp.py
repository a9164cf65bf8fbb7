"""NicoGrasp: the paper's vision-based grasping task (Section 4.1.1, Fig. 6-7) as a gymnasium environment.

A NICO-like robot seated at a table learns to grasp a glass from a 64×32 RGB image of a top-mounted camera.
The paper's text and the authors' released code differ in how the hand is used; both are offered through
`hand` (see docs/environment.md):

* ``hand="auto"`` (released code, the default): the action is the shoulder change only, ``Box(-1, 1, (1,))``
  scaled by 20°, the shoulder clipped to a reachable window of its ±100° range; a grasp attempt starts by
  itself when the hand centre is within 0.03 m of the glass centre, and succeeds below 0.03 m.
* ``hand="learned"`` (the paper's text): ``Box(-1, 1, (2,))``; ``action[1] > 0`` closes the hand and makes a
  grasp attempt; success below 0.04 m.

Task levels (`level`, core/task_levels.py) bundle the geometry and rules that differ between the released code
(``released``, the default), the paper's text (``paper``), a level where the camera is necessary and
exploration is hard (``hard``) and ``hard`` on the part of the shoulder's range the camera sees (``seen``):
shoulder window, start angle, where the glass may stand, admitted hands and grasp attempts per episode.

Grasp verification (Section 4.1.2): with the hand closed, the shoulder moves 20° opposite to its last
movement and the distance between the centres of glass and hand is measured; below the threshold is a
success (+1, the episode ends). Otherwise the hand opens, the shoulder moves back, the glass is put back where
it stood and the episode goes on. A glass tilted more than 0.2 rad from upright, or off the table, is toppled
(−1, the episode ends). Otherwise the reward is the dense shaping term (−d as the text, or −d² as the released
code) or 0 (sparse). Episodes are truncated after `max_steps` (50) steps.

The grip: when the closing fingers touch the glass from both sides (a thumb link and an index link in
contact), the glass is held by a fixed constraint to the hand for as long as the hand stays closed. This
stands in for the friction grip of NICO's tendon-driven hand, which the rigid-body solver reproduces poorly
at this time step; whether the grip happens is still decided by the physical contacts, and whether the grasp
is verified is still decided by the measured distance.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import pybullet
from gymnasium import spaces

from core.envs.camera import (
    OBS_HEIGHT,
    OBS_WIDTH,
    CameraPose,
    CameraShift,
    Lighting,
    apply_sensor_model,
    shifted_pose,
)
from core.envs.quiet_bullet import quiet_client
from core.envs.robot_description import FINGER_NAMES, ArmGeometry
from core.envs.scene_files import scene_file
from core.task_levels import get_level

REWARD_MODES = ("dense", "sparse")


def _fma(a: float, b: float, c: float) -> float:
    """a·b + c rounded once (``math.fma`` arrives in Python 3.13)."""
    return float(Fraction(a) * Fraction(b) + Fraction(c))
HAND_MODES = ("auto", "learned")
DENSE_SHAPINGS = ("distance", "squared")
DOMAINS = ("sim", "real")


@dataclass(frozen=True)
class PhysicsSettings:
    """Simulation constants. One env step moves the shoulder for `move_substeps` physics steps."""

    time_step: float = 1.0 / 240.0
    move_substeps: int = 24
    hand_substeps: int = 20
    shoulder_force: float = 60.0
    shoulder_max_velocity: float = 6.0
    shoulder_position_gain: float = 0.3
    finger_force: float = 1.5
    finger_close_rad: float = math.radians(55.0)
    table_friction: float = 0.9
    glass_friction: float = 0.9
    hand_friction: float = 1.0


class NicoGraspEnv(gym.Env):
    """The NICO-like grasping task. Observation: uint8 image (32, 64, 3). See the module docstring."""

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        reward_mode: str = "dense",
        hand: str | None = None,
        level: str = "released",
        dense_shaping: str = "distance",
        fixed_positions: int | None = None,
        max_steps: int = 50,
        domain: str = "sim",
        camera_shift: CameraShift | None = None,
        render_mode: str | None = None,
        shoulder_window_deg: tuple[float, float] | None = None,
        step_deg: float = 20.0,
        grasp_threshold: float | None = None,
        topple_tilt_rad: float = 0.2,
        positions_seed: int = 0,
        geometry: ArmGeometry | None = None,
        physics: PhysicsSettings | None = None,
    ) -> None:
        _check_choice("reward_mode", reward_mode, REWARD_MODES)
        self.level = get_level(level)
        hand = self.level.hand if hand is None else hand
        _check_choice("hand", hand, HAND_MODES)
        if hand not in self.level.hands:
            raise ValueError(
                f"level {level!r} admits hand {' or '.join(map(repr, self.level.hands))}, got {hand!r}"
            )
        _check_choice("dense_shaping", dense_shaping, DENSE_SHAPINGS)
        _check_choice("domain", domain, DOMAINS)
        if render_mode is not None:
            _check_choice("render_mode", render_mode, tuple(self.metadata["render_modes"]))
        if max_steps < 1:
            raise ValueError(f"max_steps must be >= 1, got {max_steps}")
        if fixed_positions is not None and fixed_positions < 1:
            raise ValueError(f"fixed_positions must be None or >= 1, got {fixed_positions}")
        if shoulder_window_deg is None:
            shoulder_window_deg = self.level.shoulder_window_deg
        low, high = shoulder_window_deg
        if not -100.0 <= low < high <= 100.0:
            raise ValueError(
                f"shoulder_window_deg must lie within ±100° with low < high, got {shoulder_window_deg}"
            )
        self.reward_mode = reward_mode
        self.hand = hand
        self.dense_shaping = dense_shaping
        self.max_steps = int(max_steps)
        self.domain = domain
        self.camera_shift = camera_shift if camera_shift is not None else CameraShift()
        self.render_mode = render_mode
        self.window_rad = (math.radians(low), math.radians(high))
        start = math.radians(low if self.level.start_deg is None else self.level.start_deg)
        self.start_rad = float(np.clip(start, *self.window_rad))
        self.attempts_per_episode = self.level.attempts_per_episode
        self.step_rad = math.radians(step_deg)
        self.grasp_threshold = (
            grasp_threshold if grasp_threshold is not None else (0.03 if hand == "auto" else 0.04)
        )
        self.topple_tilt_rad = topple_tilt_rad
        self.geometry = geometry or ArmGeometry()
        self.physics = physics or PhysicsSettings()

        self.observation_space = spaces.Box(0, 255, (OBS_HEIGHT, OBS_WIDTH, 3), dtype=np.uint8)
        action_dim = 1 if hand == "auto" else 2
        self.action_space = spaces.Box(-1.0, 1.0, (action_dim,), dtype=np.float32)

        self._client = quiet_client()
        self._build_scene()
        self.sim_pose = CameraPose()
        self.sim_lighting = Lighting()
        self._views = {
            "sim": self._camera_matrices(self.sim_pose),
            "real": self._camera_matrices(shifted_pose(self.sim_pose, self.camera_shift)),
        }
        self._fixed_positions = (
            self._sample_positions(np.random.default_rng(positions_seed), fixed_positions)
            if fixed_positions
            else None
        )
        self._episode_index = 0
        self._noise_rng = np.random.default_rng(self.camera_shift.seed)
        self._grip: int | None = None
        self._steps = 0
        self._attempts = 0
        self._last_move_sign = 1.0
        self.last_info: dict[str, Any] = {}

    # ------------------------------------------------------------------ scene
    def _build_scene(self) -> None:
        c, g, ph = self._client, self.geometry, self.physics
        c.setGravity(0, 0, -9.81)
        c.setTimeStep(ph.time_step)
        c.setPhysicsEngineParameter(numSolverIterations=30, deterministicOverlappingPairs=1)
        self._table = c.loadURDF(scene_file("table", g), useFixedBase=True)
        self._robot = c.loadURDF(scene_file("robot", g), useFixedBase=True)
        self._glass = c.loadURDF(scene_file("glass", g), basePosition=(0.3, -0.2, g.glass_height / 2))
        names = {c.getJointInfo(self._robot, j)[1].decode(): j for j in range(c.getNumJoints(self._robot))}
        self._shoulder = names["shoulder"]
        self._thumb_links = {names[f"thumb_{k}"] for k in (1, 2, 3)}
        self._index_links = {names[f"{f}_{k}"] for f in FINGER_NAMES[1:] for k in (1, 2, 3)}
        self._fingers = sorted(self._thumb_links | self._index_links)
        c.changeDynamics(self._table, -1, lateralFriction=ph.table_friction)
        c.changeDynamics(self._glass, -1, lateralFriction=ph.glass_friction, spinningFriction=0.001)
        for link in [self._shoulder, *self._fingers]:
            c.changeDynamics(self._robot, link, lateralFriction=ph.hand_friction)
        self._initial_state = c.saveState()

    def _camera_matrices(self, pose: CameraPose) -> tuple[list[float], list[float]]:
        view = self._client.computeViewMatrix(pose.eye, pose.target, pose.up)
        proj = self._client.computeProjectionMatrixFOV(
            pose.fov_deg, OBS_WIDTH / OBS_HEIGHT, pose.near, pose.far
        )
        return view, proj

    def _sample_positions(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """`n` graspable glass positions (shoulder angle of the grasp, radial jitter), as an [n, 2] array."""
        low, high = self.glass_window_rad
        angles = rng.uniform(low, high, size=n)
        jitter = rng.uniform(-0.008, 0.008, size=n)
        return np.stack([angles, jitter], axis=1)

    @property
    def glass_window_rad(self) -> tuple[float, float]:
        """Shoulder angles at which the glass may stand: ahead of the open fingertips at the start angle (and
        at least the level's `min_glass_offset_deg` from it), up to the end of the window."""
        g = self.geometry
        fingertip = 3 * g.finger_link_length + g.glass_radius + 0.01
        clearance = math.atan2(fingertip, g.reach) - g.hand_centre_lead
        if self.level.min_glass_offset_deg is not None:
            clearance = max(clearance, math.radians(self.level.min_glass_offset_deg))
        return self.start_rad + clearance, self.window_rad[1]

    # ------------------------------------------------------------ kinematics
    def _shoulder_angle(self) -> float:
        return self._client.getJointState(self._robot, self._shoulder)[0]

    def hand_centre(self, q: float | None = None) -> np.ndarray:
        """World position of the hand centre (the grasp point in front of the palm) at shoulder angle q."""
        g = self.geometry
        q = self._shoulder_angle() if q is None else q
        angle = q + g.hand_centre_lead
        rho = g.hand_centre_radius
        sx, sy = g.shoulder_xy
        return np.array([sx + rho * math.sin(angle), sy - rho * math.cos(angle), g.hand_height])

    def _glass_pose(self) -> tuple[np.ndarray, tuple[float, ...]]:
        pos, orn = self._client.getBasePositionAndOrientation(self._glass)
        return np.asarray(pos), orn

    def _glass_position_for(self, angle: float, jitter: float) -> tuple[float, float, float]:
        g = self.geometry
        rho = g.hand_centre_radius + jitter
        sx, sy = g.shoulder_xy
        a = angle + g.hand_centre_lead
        return (sx + rho * math.sin(a), sy - rho * math.cos(a), g.glass_height / 2)

    def grasp_angle(self) -> float:
        """The shoulder angle (rad) that puts the hand centre nearest the glass: what the oracle aims for."""
        pos, _ = self._glass_pose()
        sx, sy = self.geometry.shoulder_xy
        return math.atan2(pos[0] - sx, -(pos[1] - sy)) - self.geometry.hand_centre_lead

    # --------------------------------------------------------------- motion
    def _set_shoulder_target(self, target: float) -> None:
        ph = self.physics
        self._client.setJointMotorControl2(
            self._robot,
            self._shoulder,
            pybullet.POSITION_CONTROL,
            targetPosition=target,
            force=ph.shoulder_force,
            maxVelocity=ph.shoulder_max_velocity,
            positionGain=ph.shoulder_position_gain,
        )

    def _set_hand(self, closed: bool) -> None:
        """One tendon command drives all nine finger joints (thumb and both index fingers)."""
        target = self.physics.finger_close_rad if closed else 0.0
        n = len(self._fingers)
        self._client.setJointMotorControlArray(
            self._robot,
            self._fingers,
            pybullet.POSITION_CONTROL,
            targetPositions=[target] * n,
            forces=[self.physics.finger_force] * n,
        )

    def _simulate(self, substeps: int) -> None:
        step = self._client.stepSimulation
        for _ in range(substeps):
            step()

    def _move_shoulder(self, target: float) -> None:
        self._set_shoulder_target(target)
        self._simulate(self.physics.move_substeps)

    # ------------------------------------------------------------ outcome
    def _toppled(self) -> bool:
        pos, orn = self._glass_pose()
        up_z = self._client.getMatrixFromQuaternion(orn)[8]
        tilt = math.acos(max(-1.0, min(1.0, up_z)))
        g = self.geometry
        (cx, cy), (lx, ly) = g.table_center_xy, g.table_size
        off_table = abs(pos[0] - cx) > lx / 2 or abs(pos[1] - cy) > ly / 2 or pos[2] < 0.0
        return tilt > self.topple_tilt_rad or off_table

    def _distance(self) -> float:
        """The glass-to-hand distance, the same float on every CPU: sqrt(fma(z, z, fma(y, y, x·x))) with exact
        fused multiply-adds. ``np.linalg.norm`` calls BLAS ``ddot``, whose rounding depends on the OpenBLAS
        kernel the CPU selects (Haswell and SkylakeX kernels differ in the last bit), which made dense rewards
        machine-dependent; this is the SkylakeX kernel's order, so the released level stays bit for bit."""
        pos, _ = self._glass_pose()
        x, y, z = (float(v) for v in np.asarray(pos, dtype=np.float64) - self.hand_centre())
        return math.sqrt(_fma(z, z, _fma(y, y, x * x)))

    def _contact_both_sides(self) -> bool:
        links = {pt[4] for pt in self._client.getContactPoints(self._glass, self._robot)}
        return bool(links & self._thumb_links) and bool(links & self._index_links)

    def _attach_glass(self) -> None:
        c = self._client
        arm_pos, arm_orn = c.getLinkState(self._robot, self._shoulder)[4:6]
        glass_pos, glass_orn = c.getBasePositionAndOrientation(self._glass)
        inv_pos, inv_orn = c.invertTransform(arm_pos, arm_orn)
        rel_pos, rel_orn = c.multiplyTransforms(inv_pos, inv_orn, glass_pos, glass_orn)
        self._grip = c.createConstraint(
            self._robot,
            self._shoulder,
            self._glass,
            -1,
            pybullet.JOINT_FIXED,
            (0, 0, 0),
            rel_pos,
            (0, 0, 0),
            rel_orn,
        )
        c.changeConstraint(self._grip, maxForce=200.0)

    def _release_glass(self) -> None:
        if self._grip is not None:
            self._client.removeConstraint(self._grip)
            self._grip = None

    def _grasp_attempt(self) -> tuple[bool, bool]:
        """Close, verify by moving 20° back, undo on failure (Section 4.1.2). Returns (success, toppled)."""
        c = self._client
        q_before = self._shoulder_angle()
        glass_before = c.getBasePositionAndOrientation(self._glass)
        self._set_hand(closed=True)
        self._simulate(self.physics.hand_substeps)
        if self._contact_both_sides():
            self._attach_glass()
        verify = float(
            np.clip(q_before - self._last_move_sign * self.step_rad, -math.radians(100), math.radians(100))
        )
        self._move_shoulder(verify)
        if self._toppled():
            self._release_glass()
            return False, True
        if self._distance() < self.grasp_threshold:
            return True, False
        # Undo: open the hand, move the shoulder back and put the glass back. Only the end state matters to
        # the episode (the glass is restored anyway), so the arm is placed there instead of simulated there.
        self._release_glass()
        self._set_hand(closed=False)
        for joint in self._fingers:
            c.resetJointState(self._robot, joint, 0.0)
        c.resetJointState(self._robot, self._shoulder, q_before)
        self._set_shoulder_target(q_before)
        c.resetBasePositionAndOrientation(self._glass, *glass_before)
        c.resetBaseVelocity(self._glass, (0, 0, 0), (0, 0, 0))
        return False, False

    # ------------------------------------------------------------- gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        c = self._client
        self._release_glass()
        if seed is not None:
            # A seeded reset rebuilds the world, so that it is bit-for-bit a fresh env (restoreState alone
            # leaves solver warm-start caches behind that perturb the 6th digit).
            self._episode_index = 0
            self._noise_rng = np.random.default_rng([self.camera_shift.seed, seed])
            c.removeState(self._initial_state)
            c.resetSimulation()
            self._build_scene()
        else:
            c.restoreState(self._initial_state)
        if self._fixed_positions is not None:
            angle, jitter = self._fixed_positions[self._episode_index % len(self._fixed_positions)]
        else:
            angle, jitter = self._sample_positions(self.np_random, 1)[0]
        if options and "glass_angle_deg" in options:
            angle, jitter = math.radians(float(options["glass_angle_deg"])), 0.0
        self._episode_index += 1
        start = self.start_rad
        if options and "shoulder_deg" in options:
            start = math.radians(float(options["shoulder_deg"]))
        c.resetJointState(self._robot, self._shoulder, start)
        for joint in self._fingers:
            c.resetJointState(self._robot, joint, 0.0)
        self._set_shoulder_target(start)
        self._set_hand(closed=False)
        c.resetBasePositionAndOrientation(self._glass, self._glass_position_for(angle, jitter), (0, 0, 0, 1))
        c.resetBaseVelocity(self._glass, (0, 0, 0), (0, 0, 0))
        self._steps = 0
        self._attempts = 0
        self._last_move_sign = 1.0
        self.last_info = self._info(success=False, toppled=False, attempted=False)
        return self._observe(), dict(self.last_info)

    def step(self, action):
        action = self._validate_action(action)
        q = self._shoulder_angle()
        target = float(np.clip(q + action[0] * self.step_rad, *self.window_rad))
        if abs(target - q) > 1e-6:
            self._last_move_sign = math.copysign(1.0, target - q)
        self._move_shoulder(target)
        success = False
        toppled = self._toppled()
        attempted = False
        if not toppled:
            if self.hand == "auto":
                attempted = self._distance() <= self.grasp_threshold
            else:
                attempted = bool(action[1] > 0.0)
            if attempted:
                success, toppled = self._grasp_attempt()
                self._attempts += 1
        self._steps += 1
        out_of_attempts = (
            attempted
            and not success
            and self.attempts_per_episode is not None
            and self._attempts >= self.attempts_per_episode
        )
        if success:
            reward = 1.0
        elif toppled:
            reward = -1.0
            if self.reward_mode == "dense" and self.level.charge_early_topple:
                # The episode ends early: the steps it cuts off are charged their shaping, as if the hand
                # stayed where the glass fell, so a topple is never cheaper than a failed attempt there.
                reward += self._shaping() * (self.max_steps - self._steps)
        elif self.reward_mode == "dense":
            reward = self._shaping()
            if out_of_attempts:
                # The episode ends early, but the shaping is charged for the steps it would have had, as if
                # the hand stayed where it closed: otherwise closing at once would be the cheapest way out.
                reward *= self.max_steps - self._steps + 1
        else:
            reward = 0.0
        terminated = success or toppled or out_of_attempts
        truncated = (not terminated) and self._steps >= self.max_steps
        self.last_info = self._info(success=success, toppled=toppled, attempted=attempted)
        return self._observe(), float(reward), terminated, truncated, dict(self.last_info)

    def _shaping(self) -> float:
        """The dense reward of one step: −d (paper text) or −d² (released code), d the glass-hand distance."""
        d = self._distance()
        return -d if self.dense_shaping == "distance" else -(d * d)

    def _validate_action(self, action) -> np.ndarray:
        arr = np.asarray(action, dtype=np.float32)
        if arr.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"action must be finite, got {arr.tolist()}")
        return np.clip(arr, -1.0, 1.0)

    def _info(self, *, success: bool, toppled: bool, attempted: bool) -> dict[str, Any]:
        pos, orn = self._glass_pose()
        return {
            "success": success,
            "toppled": toppled,
            "distance": self._distance(),
            "shoulder_deg": math.degrees(self._shoulder_angle()),
            "glass_pos": tuple(float(v) for v in pos),
            "glass_orn": tuple(float(v) for v in orn),
            "grasp_angle_deg": math.degrees(self.grasp_angle()),
            "grasp_attempted": attempted,
            "grasp_attempts": self._attempts,
        }

    # ------------------------------------------------------------ cameras
    def render_observation(self, domain: str | None = None) -> np.ndarray:
        """The current state as the 64×32 camera of `domain` ("sim" or "real") sees it, uint8 (32, 64, 3)."""
        domain = domain or self.domain
        _check_choice("domain", domain, DOMAINS)
        view, proj = self._views[domain]
        light = self.sim_lighting if domain == "sim" else self.camera_shift.lighting
        image = self._render(OBS_WIDTH, OBS_HEIGHT, view, proj, light)
        if domain == "real":
            image = apply_sensor_model(image, self.camera_shift, self._noise_rng)
        return image

    def _observe(self) -> np.ndarray:
        return self.render_observation(self.domain)

    def _render(self, width: int, height: int, view, proj, light: Lighting) -> np.ndarray:
        _, _, rgba, _, _ = self._client.getCameraImage(
            width,
            height,
            view,
            proj,
            lightDirection=light.direction,
            lightAmbientCoeff=light.ambient,
            lightDiffuseCoeff=light.diffuse,
            lightSpecularCoeff=light.specular,
            shadow=0,
            renderer=pybullet.ER_TINY_RENDERER,
            flags=pybullet.ER_NO_SEGMENTATION_MASK,
        )
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3]

    def render_view(self, width: int, height: int, pose: CameraPose, domain: str = "sim") -> np.ndarray:
        """A larger picture of the scene from any camera pose (for `dualsys env show` and documentation)."""
        if domain == "real":
            pose = shifted_pose(pose, self.camera_shift)
        light = self.sim_lighting if domain == "sim" else self.camera_shift.lighting
        view = self._client.computeViewMatrix(pose.eye, pose.target, pose.up)
        proj = self._client.computeProjectionMatrixFOV(pose.fov_deg, width / height, pose.near, pose.far)
        return self._render(width, height, view, proj, light)

    def render(self):
        if self.render_mode == "rgb_array":
            return self.render_view(512, 256, OVERVIEW_POSE)
        return None

    def close(self) -> None:
        if getattr(self, "_client", None) is not None:
            with contextlib.suppress(pybullet.error):
                self._client.disconnect()
            self._client = None


OVERVIEW_POSE = CameraPose(
    eye=(0.85, -0.85, 0.75), target=(0.12, -0.12, 0.12), up=(0.0, 0.0, 1.0), fov_deg=45.0
)
"""A three-quarter view of robot, table and glass for pictures a person reads."""


def _check_choice(name: str, value: str, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ValueError(f"unknown {name} {value!r}; choose one of: {', '.join(choices)}")
