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

With ``moved`` = P, the orthogonal projection onto the latent directions the actions move where the plan
starts (`LocalWorldModels.moved_directions`), the distance is ‖P(u − ḡ)‖ and the pull acts only along those.

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
                 moved: np.ndarray | None = None) -> None:
        self.moved = None if moved is None else np.asarray(moved, dtype=np.float64)
        """P ``[d, d]``: the orthogonal projection onto the directions actions move the latent (None: all)."""
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
        if self.moved is not None:
            diff = diff @ self.moved  # P is symmetric: ‖P(u − ḡ)‖ and its gradient P(u − ḡ)/‖·‖
        distance = np.sqrt((diff * diff).sum(axis=1) + SMOOTHING**2)
        return -self.weight * distance, -self.weight * diff / distance[:, None] / self.unit
