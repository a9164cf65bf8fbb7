"""The method registry: ``ALGOS[name](config, spec, rng) -> Agent``, the names ``--algo`` accepts.

``ddpg`` and ``cacla`` are the model-free baselines of Section 2.1, ``td3`` and ``sac`` the modern learners
(the name sets ``agent.ac``); ``rnd`` is the model-free agent with random network distillation's exploration
bonus (``core.modelfree.rnd``), the intrinsic-motivation peer.
The dual-system methods (``core.dual.im2c``, ``core.dual.i2a``, ``core.dual.baselines``: im2c, i2a, cmc,
la-imagination, mve) and rnd hold the learner ``agent.ac`` names (``--ac``). The run package lists the methods
it knows here, from above; a user's own method joins with :func:`register_algo` before training.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from core.config import Config, ConfigError
from core.dual.baselines import MVE, make_cmc, make_i2a, make_im2c, make_la_imagination
from core.envs.spec import EnvSpec
from core.modelfree.agent import Agent, ModelFreeAgent
from core.modelfree.rnd import RNDAgent

AlgoFactory = Callable[[Config, EnvSpec, np.random.Generator], Agent]

ALGOS: dict[str, AlgoFactory] = {
    "ddpg": ModelFreeAgent,
    "cacla": ModelFreeAgent,
    "td3": ModelFreeAgent,
    "sac": ModelFreeAgent,
    "im2c": make_im2c,
    "i2a": make_i2a,
    "cmc": make_cmc,
    "la-imagination": make_la_imagination,
    "mve": MVE,
    "rnd": RNDAgent,
}
"""The methods by name."""

MODEL_FREE_ALGOS: tuple[str, ...] = ("ddpg", "cacla", "td3", "sac")
"""Methods whose name is their learner (``agent.ac``)."""


def register_algo(name: str, factory: AlgoFactory) -> None:
    """Register (or replace) a method factory under ``name`` (a user's own method)."""
    ALGOS[name] = factory


def resolve_algo(config: Config) -> Config:
    """Check ``run.algo`` against the registry; for ddpg/cacla make ``agent.ac`` match the name."""
    if config.run.algo not in ALGOS:
        raise ConfigError(f"unknown algo {config.run.algo!r} (choose from {', '.join(sorted(ALGOS))})")
    if config.run.algo in MODEL_FREE_ALGOS and config.agent.ac != config.run.algo:
        config = dataclasses.replace(config, agent=dataclasses.replace(config.agent, ac=config.run.algo))
    return config


def make_agent(config: Config, spec: EnvSpec, rng: np.random.Generator) -> Agent:
    """Build the agent of ``config.run.algo``."""
    config = resolve_algo(config)
    return ALGOS[config.run.algo](config, spec, rng)
