"""The ``auto`` profile: the config profile a task's observations call for (``dualsys train --profile auto``,
the default, and a service train job's default).

Vector observations get the ``vector`` profile (the textbook networks, under which every learner learns
Pendulum-v1 in 20k steps: docs/results.md, issue 28); images, NicoGrasp's among them, get ``default`` (the
paper's critic-autoencoder). Telling which needs the env built once, except for NicoGrasp; a task that cannot
be built gets ``default``, and its run then fails building it with the one-line ``EnvError`` (a service job at
its start, not at submission: the API accepts what its schema describes).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

from core.config import NICO_GRASP_ID, Config, EnvConfig, load_config
from core.envs.gym_env import EnvError, make_env

AUTO_PROFILE = "auto"
"""The profile name that picks ``vector`` or ``default`` by the task's observations."""


def observation_kind(env: EnvConfig) -> str:
    """``"image"`` or ``"vector"``: what ``env`` observes. Raises ``EnvError`` (one line) for an env that
    cannot be built."""
    if env.id == NICO_GRASP_ID:
        return "image"
    adapted = make_env(env)
    try:
        return adapted.spec.obs_kind
    finally:
        adapted.env.close()


def load_run_config(
    profile: str,
    overrides: Sequence[str] = (),
    config_file: Path | str | None = None,
    *,
    env_id: str | None = None,
) -> Config:
    """``core.config.load_config``, where ``profile = auto`` becomes ``vector`` for a task with vector
    observations and ``default`` otherwise. ``env_id`` names the task where it is set after the overrides
    (``dualsys train --env``); by default it is the overrides' ``env.id``."""
    if profile != AUTO_PROFILE:
        return load_config(profile, overrides, config_file)
    config = load_config("default", overrides, config_file)
    env = config.env if env_id is None else dataclasses.replace(config.env, id=env_id)
    try:
        kind = observation_kind(env)
    except EnvError:
        return config  # the run fails building the env, with this error, where it would have anyway
    return load_config("vector", overrides, config_file) if kind == "vector" else config
