"""How a trained encoder's latent space looks to the ITM: distances and the regions an e_max gives.

The ITM (Section 2.3.1) creates a node when a latent lies farther than e_max from its best match. e_max = 6 is
the released code's value for the authors' Keras encoder; whether it gives "regions" in another encoder's
latent scale is an empirical question. `region_scale` answers it for a policy: it encodes the states a
uniform random policy visits on the policy's own task level, reports the distances between consecutive
latents and between arbitrary pairs, and streams the same latents through a fresh ITM for each candidate
e_max to count the nodes it would create (issue 11's ablation "the number of regions").
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from core.dual.itm import InstantaneousTopologicalMap
from core.dual.readings import resolve
from core.envs import NicoGraspEnv
from core.runs.policy import load_policy

QUANTILES = (0.05, 0.5, 0.95)


def collect_observations(env: NicoGraspEnv, episodes: int, seed: int) -> np.ndarray:
    """uint8 observations ``[T, 32, 64, 3]`` of `episodes` uniform-random episodes, in visiting order."""
    rng = np.random.default_rng(seed)
    frames = []
    for episode in range(episodes):
        obs, _ = env.reset(seed=seed + episode)
        frames.append(obs)
        done = False
        while not done:
            obs, _, terminated, truncated, _ = env.step(
                rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
            )
            frames.append(obs)
            done = terminated or truncated
    return np.stack(frames)


def _quantiles(values: np.ndarray) -> dict[str, float]:
    return {f"q{int(q * 100):02d}": float(np.quantile(values, q)) for q in QUANTILES}


def itm_node_count(latents: np.ndarray, e_max: float, distance: str) -> int:
    """Nodes of a fresh ITM after streaming `latents` through it in order."""
    itm = InstantaneousTopologicalMap(latents.shape[1], e_max, distance=distance)  # type: ignore[arg-type]
    for phi in latents:
        itm.update(phi)
    return itm.num_nodes


def region_scale(
    policy_path: Path | str,
    episodes: int = 40,
    e_max_values: Sequence[float] = (6.0, 3.0, 1.5, 0.75, 0.375),
    seed: int = 0,
    pairs: int = 20_000,
) -> dict:
    """Latent distances of the encoder of `policy_path` and the ITM nodes per e_max (module docstring)."""
    policy = load_policy(policy_path)
    env_cfg = policy.config.env
    env = NicoGraspEnv(level=env_cfg.level, hand=env_cfg.hand, reward_mode=env_cfg.reward_mode)
    try:
        frames = collect_observations(env, episodes, seed)
    finally:
        env.close()
    with torch.no_grad():
        latents = policy.encode(frames).astype(np.float64)
    consecutive = np.linalg.norm(np.diff(latents, axis=0), axis=1)
    rng = np.random.default_rng(seed)
    a, b = rng.integers(0, len(latents), size=(2, pairs))
    pairwise = np.linalg.norm(latents[a] - latents[b], axis=1)
    distance = resolve(policy.config.dual).regions.distance
    configured = policy.config.dual.e_max
    values = sorted({float(v) for v in (*e_max_values, configured)}, reverse=True)
    return {
        "policy": str(policy.source),
        "level": env_cfg.level,
        "states": len(latents),
        "itm_distance": distance,
        "configured_e_max": configured,
        "latent_norm": _quantiles(np.linalg.norm(latents, axis=1)),
        "consecutive_distance": _quantiles(consecutive),
        "pairwise_distance": _quantiles(pairwise),
        "nodes": {f"{v:g}": itm_node_count(latents, v, distance) for v in values},
    }
