"""Check: ITM regions do not depend on the latent's scale (Section 2.3.1; ``dual.regions``,
``dual.e_max``, ``dual.region_prune_after``).

Purpose: the map should cut the latent space into regions of a chosen resolution whatever units the encoder
happens to produce. e_max = 6 is the released code's value for the authors' encoder; ours starts with latent
distances near 0.01 and ends near 1.5 (docs/results.md), so the literal map stays at 2–3 nodes, and an e_max
relative to recent latents without normalising the map grew to 243–278 stale nodes. The check streams one
latent stream, multiplied by 0.01, 1 and 100, through `LocalWorldModels.observe_state` and counts the nodes.

`episode_stream` imitates a trained NicoGrasp encoder's latents (`dualsys diagnose regions`: latent norms
2–3.6, pairwise distances around 1.5): episodes of 20 steps of a smooth walk on a 3-D manifold (arm angle,
hand, glass position) that starts at a random point each episode, embedded in R^32 by a fixed random ReLU
layer and scaled so the median pairwise distance is about 1.5.
"""

from __future__ import annotations

import numpy as np
import torch

from core.config import DualConfig
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels

SCALES = (0.01, 1.0, 100.0)


def episode_stream(states: int, seed: int, latent_dim: int = 32, manifold: int = 3,
                   episode: int = 20) -> np.ndarray:
    """``[states, latent_dim]`` latents (module docstring)."""
    rng = np.random.default_rng(seed)
    weights = rng.normal(size=(latent_dim, manifold))
    bias = rng.normal(size=latent_dim) * 0.5
    points = np.empty((states, manifold))
    for start in range(0, states, episode):
        position = rng.uniform(-1.0, 1.0, size=manifold)
        for t in range(start, min(states, start + episode)):
            points[t] = position
            position = np.clip(position + rng.normal(0.0, 0.08, size=manifold), -1.0, 1.0)
    latents = np.maximum(points @ weights.T + bias, 0.0)
    pairs = rng.integers(0, states, size=(2, 2000))
    median = np.median(np.linalg.norm(latents[pairs[0]] - latents[pairs[1]], axis=1))
    return latents * (1.5 / median)


def node_count(dual: DualConfig, latents: np.ndarray, seed: int = 0) -> int:
    """Live ITM nodes after streaming ``latents`` through a fresh `LocalWorldModels` (no action needed)."""
    world = LocalWorldModels(dual, latents.shape[1], 1, generator=torch.Generator().manual_seed(seed),
                             readings=resolve(dual))
    for phi in torch.from_numpy(latents).float():
        world.observe_state(phi)
    return world.num_nodes


def regions_check(dual: DualConfig, states: int = 4000, seed: int = 0) -> dict[str, dict[str, int]]:
    """The JSON figures: nodes of the same stream at each scale of `SCALES`."""
    latents = episode_stream(states, seed)
    counts = {f"{scale:g}": node_count(dual, latents * scale, seed) for scale in SCALES}
    return {"nodes_by_latent_scale": counts}
