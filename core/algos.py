"""The method registry: ``ALGOS[name](config, spec, rng) -> Agent``.

A method plugs into the shared trainer by registering a factory here (or from its own module with
:func:`register_algo`, imported by :func:`load_algos`); the CLI and the service validate ``--algo``
against this registry at run time, so names registered later are accepted without code changes.

``ddpg`` and ``cacla`` are the model-free baselines of Section 2.1 (the name sets ``agent.ac``).
Dual-system methods (im2c, i2a, mve, cmc, la-imagination) read ``agent.ac`` for their actor rule.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Callable

import numpy as np

from core.agent import Agent, EnvSpec, ModelFreeAgent
from core.config import Config, ConfigError

AlgoFactory = Callable[[Config, EnvSpec, np.random.Generator], Agent]

ALGOS: dict[str, AlgoFactory] = {}
"""Registered methods by name."""

MODEL_FREE_ALGOS: tuple[str, ...] = ("ddpg", "cacla")
"""Methods whose name is their actor-update rule (``agent.ac``)."""

PLUGIN_MODULES: tuple[str, ...] = ("core.dual_algos",)
"""Modules that register further methods when imported (missing ones are skipped)."""


def register_algo(name: str, factory: AlgoFactory) -> None:
    """Register (or replace) a method factory under ``name``."""
    ALGOS[name] = factory


def load_algos() -> dict[str, AlgoFactory]:
    """Import the plugin modules so that every method is registered; returns the registry."""
    for module in PLUGIN_MODULES:
        try:
            importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name != module:
                raise
    return ALGOS


def resolve_algo(config: Config) -> Config:
    """Check ``run.algo`` against the registry; for ddpg/cacla make ``agent.ac`` match the name."""
    algos = load_algos()
    if config.run.algo not in algos:
        raise ConfigError(f"unknown algo {config.run.algo!r} (choose from {', '.join(sorted(algos))})")
    if config.run.algo in MODEL_FREE_ALGOS and config.agent.ac != config.run.algo:
        config = dataclasses.replace(config, agent=dataclasses.replace(config.agent, ac=config.run.algo))
    return config


def make_agent(config: Config, spec: EnvSpec, rng: np.random.Generator) -> Agent:
    """Build the agent of ``config.run.algo``."""
    config = resolve_algo(config)
    return ALGOS[config.run.algo](config, spec, rng)


register_algo("ddpg", ModelFreeAgent)
register_algo("cacla", ModelFreeAgent)
