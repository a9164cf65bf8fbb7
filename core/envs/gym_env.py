"""Any gymnasium task as a dualsys environment: build it from ``config.env``, check its spaces, adapt them.

``make_env(env_config)`` builds NicoGrasp (the default id, with its own keyword arguments, unchanged) or
``gymnasium.make(id, **kwargs)`` for any other registered id; ``dm_control/...`` ids come from shimmy
(the ``dmc`` extra). The spaces the agents support, and what is done to them (SB3's
``common/preprocessing.py`` rules, with gymnasium's own wrappers):

* observations: a ``Box`` of uint8 ``H×W×C`` is an image (channel-first ``C×H×W`` with C in 1, 3, 4 is
  detected and transposed, and said); a ``Box`` of uint8 ``H×W`` gets a channel axis; a float ``Box``
  is a vector (more than one axis: flattened); a ``Dict`` of Boxes is flattened (``FlattenObservation``).
  Anything else (Discrete, MultiBinary, Tuple, Text, Graph, ...) is an :class:`EnvError`.
* actions: a ``Box`` with finite bounds, of any dimension (more than one axis is refused). Bounds other
  than ±1 are rescaled to the agent's [-1, 1] by ``RescaleAction`` (see ``core.envs.spec``). Unbounded
  or discrete action spaces are an :class:`EnvError`.

Every error is one line that says what is wrong and what is supported; the CLI prints it and exits 2
before a run directory exists.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.wrappers import (
    FlattenObservation,
    RescaleAction,
    ReshapeObservation,
    TransformObservation,
    TransformReward,
)

from core.config import NICO_GRASP_ID, EnvConfig
from core.envs.spec import EnvSpec

CHANNELS = (1, 3, 4)
"""Channel counts an image axis may have (grey, RGB, RGBA)."""


class EnvError(ValueError):
    """An environment dualsys cannot build or train on; the message is one line for the user."""


@dataclass
class AdaptedEnv:
    """A built environment after the wrappers, with its spec and what was done to it."""

    env: gym.Env
    spec: EnvSpec
    notes: list[str] = field(default_factory=list)
    """One line per adaptation (e.g. "channel-first images transposed to H×W×C"), for the user."""


def nico_grasp_kwargs(config: EnvConfig) -> dict[str, Any]:
    """The ``NicoGraspEnv`` keyword arguments of ``config``."""
    return {
        "level": config.level,
        "reward_mode": config.reward_mode,
        "hand": config.hand,
        "dense_shaping": config.dense_shaping,
        "fixed_positions": config.fixed_positions,
        "max_steps": config.max_steps,
        "domain": config.domain,
    }


def make_env(config: EnvConfig, *, evaluation: bool = False, rescale_actions: bool = True) -> AdaptedEnv:
    """The environment of ``config``, wrapped for the agents. ``evaluation``: NicoGrasp's evaluation env
    (a new random graspable position every reset); other tasks are built the same way for both.
    ``rescale_actions=False`` leaves the env's own action units (for a deployed policy, which has the
    bounds in its last layer)."""
    if config.id == NICO_GRASP_ID:
        if config.kwargs or config.reward_offset:
            raise EnvError(
                "env.kwargs and env.reward_offset are for tasks other than NicoGrasp; NicoGrasp takes "
                "env.level, env.reward_mode, env.hand, env.dense_shaping, env.fixed_positions, "
                "env.max_steps, env.domain"
            )
        from core.envs.nico_grasp import NicoGraspEnv

        kwargs = nico_grasp_kwargs(config)
        if evaluation:
            kwargs["fixed_positions"] = None
        return adapt(NicoGraspEnv(**kwargs), rescale_actions=rescale_actions)
    env = make_gym_env(config.id, config.kwargs)
    if config.reward_offset:
        offset = float(config.reward_offset)
        env = TransformReward(env, lambda reward: reward + offset)
    return adapt(env, rescale_actions=rescale_actions)


def make_gym_env(env_id: str, kwargs: dict[str, Any] | None = None) -> gym.Env:
    """``gymnasium.make(env_id, **kwargs)`` with one-line errors (unknown id, missing extra, bad kwargs, an
    env whose constructor fails, e.g. a retired MuJoCo v2/v3 id that raises ImportError)."""
    namespace = env_id.split("/", 1)[0] if "/" in env_id else None
    if namespace == "dm_control":
        _quiet_mujoco_gl()
        try:
            import shimmy
        except ImportError:
            raise EnvError(
                f"{env_id} needs dm_control through shimmy: pip install 'dualsys[dmc]'"
            ) from None
        gym.register_envs(shimmy)
    elif namespace == "dualsys":
        import core.envs  # noqa: F401  (registers the dualsys ids)
    try:
        return gym.make(env_id, **(kwargs or {}))
    except gym.error.Error as error:
        first = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise EnvError(f"unknown env id {env_id!r}: {first} (list the ids with `dualsys env list`)") from None
    except TypeError as error:
        raise EnvError(f"bad env.kwargs for {env_id}: {error}") from None
    except Exception as error:  # the env's own constructor failed (a missing optional package, its checks)
        first = str(error).splitlines()[0] if str(error) else ""
        raise EnvError(f"cannot build {env_id}: {type(error).__name__}: {first}") from None


def adapt(env: gym.Env, *, rescale_actions: bool = True) -> AdaptedEnv:
    """Check ``env``'s spaces and wrap it (observation layout, action rescaling); see the module docstring."""
    notes: list[str] = []
    env = _adapt_observation(env, notes)
    env, low, high = _adapt_action(env, notes, rescale_actions)
    space = env.observation_space
    assert isinstance(space, spaces.Box)
    kind = "image" if space.dtype == np.uint8 and len(space.shape) == 3 else "vector"
    obs_low = obs_high = None
    if kind == "vector" and np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high)):
        obs_low = tuple(float(v) for v in space.low.reshape(-1))
        obs_high = tuple(float(v) for v in space.high.reshape(-1))
    spec = EnvSpec(
        obs_shape=tuple(int(v) for v in space.shape),
        action_dim=int(low.shape[0]),
        obs_kind=kind,
        obs_dtype=str(space.dtype),
        obs_low=obs_low,
        obs_high=obs_high,
        action_low=tuple(float(v) for v in low),
        action_high=tuple(float(v) for v in high),
    )
    return AdaptedEnv(env=env, spec=spec, notes=notes)


def _space_name(space: spaces.Space) -> str:
    if isinstance(space, spaces.Box):
        return f"Box{tuple(space.shape)} of {space.dtype}"
    return str(space)


def _adapt_observation(env: gym.Env, notes: list[str]) -> gym.Env:
    space = env.observation_space
    if isinstance(space, spaces.Dict):
        inner = [name for name, sub in space.spaces.items() if not isinstance(sub, spaces.Box)]
        if inner:
            raise EnvError(
                f"unsupported observation space: Dict with a non-Box entry {inner[0]!r} "
                "(supported: Box images, Box vectors, Dict of Boxes)"
            )
        env = FlattenObservation(env)
        notes.append(f"Dict observations flattened to a vector of {env.observation_space.shape[0]}")
        space = env.observation_space
    if not isinstance(space, spaces.Box):
        raise EnvError(
            f"unsupported observation space: {_space_name(space)} "
            "(supported: Box uint8 images H×W×C, Box float vectors, Dict of Boxes)"
        )
    shape = space.shape
    if space.dtype == np.uint8 and len(shape) == 3:
        if shape[-1] not in CHANNELS and shape[0] in CHANNELS:
            hwc = spaces.Box(0, 255, (shape[1], shape[2], shape[0]), np.uint8)
            env = TransformObservation(env, lambda obs: np.ascontiguousarray(np.moveaxis(obs, 0, -1)), hwc)
            notes.append(f"channel-first images {list(shape)} transposed to H×W×C {list(hwc.shape)}")
        return env
    if space.dtype == np.uint8 and len(shape) == 2:
        env = ReshapeObservation(env, (*shape, 1))
        notes.append(f"grey images {list(shape)} given a channel axis")
        return env
    if not np.issubdtype(space.dtype, np.floating) and space.dtype != np.uint8:
        raise EnvError(
            f"unsupported observation dtype {space.dtype} in {_space_name(space)} "
            "(supported: uint8 images, float vectors)"
        )
    if len(shape) != 1:
        env = FlattenObservation(env)
        notes.append(f"observations of shape {list(shape)} flattened to a vector")
    return env


def _adapt_action(
    env: gym.Env, notes: list[str], rescale: bool = True
) -> tuple[gym.Env, np.ndarray, np.ndarray]:
    space = env.action_space
    if not isinstance(space, spaces.Box):
        raise EnvError(
            f"unsupported action space: {_space_name(space)} (supported: a Box with finite bounds)"
        )
    if len(space.shape) != 1:
        raise EnvError(f"unsupported action space: Box of shape {list(space.shape)} (supported: 1-D Box)")
    low, high = space.low.astype(np.float64), space.high.astype(np.float64)
    if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
        raise EnvError(
            f"unsupported action space: unbounded Box (low {low.tolist()}, high {high.tolist()}); "
            "give it finite bounds (e.g. gymnasium.wrappers.ClipAction on a bounded copy)"
        )
    if np.any(high <= low):
        raise EnvError(f"unsupported action space: empty Box (low {low.tolist()}, high {high.tolist()})")
    if rescale and not (np.all(low == -1.0) and np.all(high == 1.0)):
        unit = np.ones(space.shape, dtype=space.dtype)
        env = RescaleAction(env, -unit, unit)
        notes.append(f"actions rescaled from [-1, 1] to the env's bounds {low.tolist()} .. {high.tolist()}")
    return env, low, high


def episode_success(info: dict[str, Any], terminated: bool, truncated: bool, rule: str) -> bool:
    """Whether an episode that ended with ``info`` succeeded, by ``env.success`` (see ``EnvConfig``)."""
    if rule == "terminated":
        return bool(terminated and not truncated)
    return bool(info.get("success", info.get("is_success", False)))


def _quiet_mujoco_gl() -> None:
    """dm_control picks a GL backend at import (GLFW by default, which warns without a display); state
    observations need none, so default to EGL unless the user chose one (``MUJOCO_GL``)."""
    os.environ.setdefault("MUJOCO_GL", "egl")


def registered_ids() -> list[str]:
    """Every gymnasium id registered now (after importing dualsys's envs and, when installed, shimmy's)."""
    import core.envs  # noqa: F401

    _quiet_mujoco_gl()
    try:
        import shimmy

        gym.register_envs(shimmy)
    except ImportError:
        pass
    return sorted(gym.registry)
