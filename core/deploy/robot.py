"""The robot a deployed policy drives: a small ``Robot`` protocol and its simulator implementation.

Section 4.2 of the paper describes a grasp trial on the physical NICO as four robot operations: the robot
*places the object* at a known graspable position and returns the arm to its start pose; then, repeatedly,
the external camera *captures an image*, the actor network turns it into a motor command that the robot
*executes*, and the robot *verifies the grasp* (is the object in the closed hand?). :class:`Robot` is
exactly these four operations; the 8-step evaluator (:mod:`core.deploy.grasp_trials`) is written against
it only, so a driver for a physical robot plugs in without touching the evaluator (skeleton in
``docs/deployment.md``). :class:`SimRobot` implements it on NicoGrasp for both camera domains: ``"sim"``
(the simulator's camera) and ``"real"`` (the real-camera stand-in of ``core.envs.CameraShift``).

Decision: a grasp attempt is part of executing a motor command. With ``hand="auto"`` (the released code)
the robot starts it by itself when the hand reaches the object; with ``hand="learned"`` (the paper's text)
the command's second component closes the hand. ``execute`` reports whether an attempt happened and
whether the object was knocked over; ``verify_grasp`` reports whether the object is held.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from core.envs import CameraShift, NicoGraspEnv

SIM_ROBOT_EPISODE_LIMIT = 1_000_000
"""SimRobot's env never truncates on its own: the evaluator decides when a trial ends."""


@dataclass(frozen=True)
class MotorResult:
    """What executing one motor command did."""

    grasp_attempted: bool
    """The hand closed on this command (automatically, or because the command asked for it)."""
    toppled: bool
    """The object was knocked over or pushed off the table: the trial has failed."""


@runtime_checkable
class Robot(Protocol):
    """The four operations of a grasp trial (Section 4.2). Images are uint8 ``[32, 64, 3]`` RGB."""

    @property
    def action_dim(self) -> int:
        """Length of a motor command (1: shoulder change, automatic hand; 2: shoulder change, close)."""
        ...

    def place_object(self, seed: int) -> None:
        """Put the object at a graspable position chosen by ``seed`` and move the arm to its start pose."""
        ...

    def capture_image(self) -> np.ndarray:
        """One image of the scene from the top-mounted camera, uint8 ``[32, 64, 3]``."""
        ...

    def execute(self, action: np.ndarray) -> MotorResult:
        """Execute one motor command in [-1, 1]^action_dim (shoulder change × 20°, hand), wait until done."""
        ...

    def verify_grasp(self) -> bool:
        """True when the object is held in the hand after the last command (the paper's verification)."""
        ...


class SimRobot:
    """:class:`Robot` on the NicoGrasp simulator, seen through the ``"sim"`` or the ``"real"`` camera."""

    def __init__(
        self,
        *,
        domain: str = "sim",
        hand: str | None = None,
        camera_shift: CameraShift | None = None,
        **env_kwargs: Any,
    ) -> None:
        self.env = NicoGraspEnv(
            domain=domain,
            hand=hand,
            camera_shift=camera_shift,
            max_steps=SIM_ROBOT_EPISODE_LIMIT,
            **env_kwargs,
        )
        self.domain = domain
        self._image: np.ndarray | None = None
        self._info: dict[str, Any] = {}

    @property
    def action_dim(self) -> int:
        return int(self.env.action_space.shape[0])

    @property
    def last_info(self) -> dict[str, Any]:
        """The env's diagnostics after the last operation (for tests and scripted oracles; not in Robot)."""
        return self._info

    def place_object(self, seed: int) -> None:
        self._image, self._info = self.env.reset(seed=int(seed))

    def capture_image(self) -> np.ndarray:
        if self._image is None:
            raise RuntimeError("place_object must be called before capture_image")
        return self._image

    def execute(self, action: np.ndarray) -> MotorResult:
        if self._image is None:
            raise RuntimeError("place_object must be called before execute")
        self._image, _, _, _, self._info = self.env.step(np.asarray(action, dtype=np.float32))
        return MotorResult(
            grasp_attempted=bool(self._info["grasp_attempted"]), toppled=bool(self._info["toppled"])
        )

    def verify_grasp(self) -> bool:
        return bool(self._info.get("success", False))

    def close(self) -> None:
        self.env.close()

    def __enter__(self) -> SimRobot:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
