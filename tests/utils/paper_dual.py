"""The ``paper`` profile's dual section as ``--set`` overrides of the default profile (test set-up only)."""

from __future__ import annotations

import dataclasses

from core.config import DualConfig, load_config


def paper_dual_overrides() -> list[str]:
    """``dual.<field>=<value>`` for every field where the paper's dual section differs from the default's: a
    default-profile run with these overrides has the literal dual reading and the default's everything
    else."""
    paper, default = load_config("paper").dual, DualConfig()
    return [f"dual.{f.name}={getattr(paper, f.name)}" for f in dataclasses.fields(DualConfig)
            if getattr(paper, f.name) != getattr(default, f.name)]
