"""The aiming planners' goal: the centre of the map's regions that stand out, and the pull toward it.

The planner's aim (``dual.planner`` = ``progress``, ``novelty`` or ``disagreement``;
`core.dual.readings.Planner.aim`) is a value per ITM region — its learning progress, prediction error or
ensemble disagreement. `RegionGoal` turns those values into one goal in the map's coordinates u(φ) (φ, or
φ / s with a normalised map), the centre of the live nodes c_n weighted by their values v_n, and a term the
plan maximises (Eq. 7's gradient MPC, `core.dual.planning.optimise_plan`):

    w_n = max(v_n − v̄, 0),   ḡ = Σ_n w_n c_n / Σ_n w_n,   g(φ) = −w_max · √(‖u(φ) − ḡ‖² + ε²),

with v̄ the mean value over the live regions and w_max = max_n w_n. Only the regions that stand out pull:
with the raw values as weights, nearly equal values put the goal at the map's centre whatever lies there (on
the controlled check that was the learnable third, by geometry; docs/dual-system.md). A plan is pulled toward
where the values stand out from anywhere on the map; the pull has unit length in u, scaled by the largest
contrast, so it fades as the values even out or go to 0 and the extrinsic return takes over; ε (1e-3, map
units) keeps it smooth at the goal. No value above the mean: no aim (g = 0).

How actions move the latent toward the goal is the start node's action map B (`LocalWorldModels.action_map`:
a least-squares fit of Δφ on the action over the node's stored transitions, kept along the directions that
persist from step to step and that the actions move significantly). The pull is summed over the plan's latents
predicted by B, φ̃_{h+1} = φ_t + Σ_{i≤h} B â_i, not by the local models (`plan_term`): on the controlled check
a local model's ∂φ̂/∂a along a direction that moves little (a point's position, 0.05 per unit action) beside
one that moves much (a screen) had the wrong sign in nodes with few or noisy transitions, and the pull toward
the goal's screen value, which no plan can keep, outweighed the pull toward its position
(docs/dual-system.md, item 11). No action map (too few transitions): no pull.

Why a goal and not a field over the regions: a softmax field g(φ) = Σ_n softmax(−‖u − c_n‖²/2σ²)_n v_n (the
first design) is flat deep inside a region, so it pulls only within about e_max of a boundary, and its
gradient along latent directions no action moves outweighed the rest. On the controlled check with the true
aim (`core.dual.checks.planner_aim.machinery_check`, docs/dual-system.md) the goal kept the planner in the
learnable third far more than the field did.
"""

from __future__ import annotations

import numpy as np

SMOOTHING = 1e-3
"""ε of the pull's norm, in map units."""


class RegionGoal:
    """g(φ) and ∂g/∂φ from node positions ``centres [N, d]`` (map coordinates) and ``values [N]``."""

    def __init__(self, centres: np.ndarray, values: np.ndarray, unit: float | None = None,
                 action_map: np.ndarray | None = None) -> None:
        self.action_map = None if action_map is None else np.asarray(action_map, dtype=np.float64)
        """B ``[d, action]``: how an action moves the latent where the plan starts (None: no pull)."""
        self.centres = np.asarray(centres, dtype=np.float64)
        self.values = np.clip(np.asarray(values, dtype=np.float64).reshape(-1), 0.0, None)
        """v_n, each region's value (clipped at 0)."""
        if self.centres.shape[0] != self.values.shape[0]:
            raise ValueError("one value per centre")
        contrast = np.clip(self.values - self.values.mean(), 0.0, None) if self.values.size else self.values
        """w_n = max(v_n − v̄, 0)."""
        self.unit = 1.0 if unit is None else float(unit)
        total = float(contrast.sum())
        self.weight = float(contrast.max()) if total > 0.0 else 0.0
        """w_max: the pull's length in u (0: no aim)."""
        self.goal = contrast @ self.centres / total if total > 0.0 else None
        """ḡ in map coordinates (None: no aim)."""

    def __call__(self, latents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """g of each row of ``latents [H, d]`` (``[H]``) and its gradient w.r.t. the latent (``[H, d]``)."""
        u = np.asarray(latents, dtype=np.float64).reshape(-1, self.centres.shape[1]) / self.unit
        if self.goal is None:
            return np.zeros(u.shape[0]), np.zeros_like(u)
        diff = u - self.goal
        distance = np.sqrt((diff * diff).sum(axis=1) + SMOOTHING**2)
        return -self.weight * distance, -self.weight * diff / distance[:, None] / self.unit

    def plan_term(self, phi: np.ndarray, plan: np.ndarray) -> tuple[float, np.ndarray]:
        """Σ_h g(φ̃_{h+1}) over the plan ``[H, action]`` from ``phi`` ``[d]``, the latents predicted by the
        action map, φ̃_{h+1} = φ + Σ_{i≤h} B â_i, and its gradient w.r.t. the plan,
        ∂/∂â_i = Bᵀ Σ_{h≥i} ∇g(φ̃_{h+1}) (0 and zeros without an action map or an aim)."""
        if self.action_map is None or self.goal is None:
            return 0.0, np.zeros_like(plan)
        start = np.asarray(phi, dtype=np.float64).reshape(1, -1)
        latents = start + np.cumsum(plan @ self.action_map.T, axis=0)
        values, grads = self(latents)
        later = np.cumsum(grads[::-1], axis=0)[::-1]  # row i: Σ_{h≥i} ∇g(φ̃_{h+1})
        return float(values.sum()), later @ self.action_map
