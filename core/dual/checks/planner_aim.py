"""Check: a planner that aims at learning progress goes where a model is improving, then moves on, and is not
drawn to noise (``dual.planner = progress``; issue 50).

Purpose: before the first extrinsic reward a planner whose objective holds only the predicted reward has
nothing to aim at (its optimal plan is to stand still under an action cost). The ``progress`` reading adds
the learning progress of the regions a plan reaches (`core.dual.planning.optimise_plan` with a
`RegionField`), so the planner should steer toward the region whose dynamics are being learnt, leave it once
it is learnt, and spend no more time in a noisy TV than a random walk does. The ``novelty`` reading
(prediction error in place of progress) is the contrast: prediction error stays high in the noise, so it
should be drawn there; ``disagreement`` (an ensemble's variance, Plan2Explore's aim) is the peer that aims at
uncertainty rather than progress.

The controlled problem is `core.envs.three_regions.ThreeRegionsEnv` (a trivial, a learnable and a noise
third of the square), with no extrinsic reward. The dual system is the agents' own: φ = the observation (the
encoder is the identity), `LocalWorldModels` learns from every real transition, `MetaController` decides
(model-based when the region is trusted: Alg. 1's rollout of a zero actor, then K gradient steps on the
reading's objective), and the executed action is the plan's first action plus N(0, 0.3²) noise, clipped; when
the region is not trusted the action is uniform random (the random walk's). The baseline is that random walk.

Figures, averaged over seeds: each planner's share of steps in the learnable region over the first and the
second half of the run, its share in the noise over the whole run, and the random walk's.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from core.config import DualConfig
from core.dual.meta_controller import MetaController
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels
from core.envs.three_regions import REGIONS, ThreeRegionsEnv, region_of

PLAN_NOISE = 0.3
"""Std of the Gaussian exploration noise around the plan's action (the learners' order of magnitude)."""


def _zero_actor(phi: torch.Tensor) -> torch.Tensor:
    return torch.zeros(phi.reshape(-1, 3).shape[0], 2)


def visits(dual: DualConfig | None, steps: int, seed: int) -> np.ndarray:
    """Region index of every step's new position: the planner of ``dual`` (None: the random walk)."""
    env = ThreeRegionsEnv(max_steps=steps)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    world = meta = None
    if dual is not None:
        world = LocalWorldModels(dual, 3, 2, generator=torch.Generator().manual_seed(seed),
                                 readings=resolve(dual))
        meta = MetaController(world, dual)
    regions = np.zeros(steps, dtype=np.int64)
    for step in range(steps):
        phi = torch.from_numpy(obs.astype(np.float32))
        action = rng.uniform(-1.0, 1.0, size=2)
        if world is not None and meta is not None:
            node = world.observe_state(phi)
            decision = meta.decide(phi, node, _zero_actor)
            if decision.model_based:
                action = np.clip(decision.action.numpy() + PLAN_NOISE * rng.normal(size=2), -1.0, 1.0)
        nxt, _, terminated, truncated, _ = env.step(action.astype(np.float32))
        if world is not None:
            world.learn_transition(node, phi, torch.from_numpy(action.astype(np.float32)), 0.0,
                                   torch.from_numpy(nxt.astype(np.float32)))
        regions[step] = int(region_of(nxt[0]))
        obs = nxt
        if terminated or truncated:
            obs, _ = env.reset()
    return regions


def _shares(regions: np.ndarray) -> dict[str, float]:
    half = regions.size // 2
    learnable, noise = REGIONS.index("learnable"), REGIONS.index("noise")
    return {
        "learnable_share_first_half": float((regions[:half] == learnable).mean()),
        "learnable_share_second_half": float((regions[half:] == learnable).mean()),
        "noise_share": float((regions == noise).mean()),
    }


def planner_aim_check(dual: DualConfig, steps: int = 12000, seeds: int = 3) -> dict[str, float]:
    """The JSON figures (module docstring): ``progress_…``, ``novelty_…``, ``disagreement_…`` and
    ``random_walk_…`` shares."""
    out: dict[str, float] = {}
    planners = (("progress", "progress"), ("novelty", "novelty"), ("disagreement", "disagreement"),
                ("random_walk", None))
    for name, reading in planners:
        config = None if reading is None else dataclasses.replace(dual, planner=reading)
        figures = [_shares(visits(config, steps, seed)) for seed in range(seeds)]
        for key in figures[0]:
            out[f"{name}_{key}"] = round(float(np.mean([f[key] for f in figures])), 3)
    return out
