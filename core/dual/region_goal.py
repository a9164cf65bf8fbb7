"""The aiming planners' goal: where the map's regions stand out, on average over map neighbours, and the pull
toward it.

The planner's aim (``dual.planner`` = ``progress``, ``novelty`` or ``disagreement``;
`core.dual.readings.Planner.aim`) is a value per ITM region — its learning progress, prediction error or
ensemble disagreement. `RegionGoal` turns those values into one goal in the map's coordinates u(φ) (φ, or
φ / s with a normalised map) and a term the plan maximises (Eq. 7's gradient MPC,
`core.dual.planning.optimise_plan`). Each value is first averaged with its map neighbours' (A the live nodes'
adjacency, the ITM's edges) and capped at the node's own value, the goal is the node (or the mean of the
nodes) where that capped average peaks, and the pull's length is the peak's contrast:

    s_n = min(v_n, (v_n + Σ_m A_nm v_m) / (1 + Σ_m A_nm)),   ḡ = c_{argmax s},   w = max_n s_n − s̄,
    g(φ) = −w · √(‖u(φ) − ḡ‖² + ε²),

with v_n clipped at 0 and s̄ the mean over the live nodes. Why a smoothed peak (docs/dual-system.md, items
14-16): the contrast-weighted centre of every node above the mean (the previous goal) fell between the
learnable third and the single nodes of the noise third whose values fluctuate, in the middle third, though
on the planner's own visits the learnable third's mean value ranked highest in 16 of 20 snapshots; the single
highest node chased those fluctuations. A region that is being learnt is many neighbouring nodes with high
values; noise is single nodes that stand out now and then, and a neighbour average keeps the first and damps
the second. Why capped at the node's own value (item 17): uncapped, a node of value 0 beside one high node
outscored that node when the high node had more neighbours — on the machinery check with the true aim (values
1 in the learnable third, 0 elsewhere) the goal sat for thousands of steps at a node of the middle third, then
of the noise third, linked by a long ITM edge to the learnable third's one node. The cap (probe 7) put the
true aim's planner in the learnable third 0.874 of its steps; the value-weighted centre of the peak's
neighbourhood (the other repair tried) did better with the planner gated by the models' reliability, but with
the aim steering where the models are not trusted (`core.dual.meta_controller`, the progress reading) the cap
did better on the same tuning seeds (learnable share of the second half 0.443 against 0.300, paired p =
0.043; item 17, probes 8 and 9). The pull has unit length in u, scaled by the contrast, so it fades as the
values even out or go to 0 and the extrinsic return takes over; ε (1e-3, map units) keeps it smooth at the
goal. No contrast (all smoothed values equal): no aim.

How actions move the latent toward the goal is the start node's `ActionMap` (`core.dual.action_map`: a
least-squares fit of Δφ on the action, the state and a constant over the node's stored transitions, kept along
the directions that persist from step to step). The pull is summed over the plan's latents that map predicts,
φ̃_{h+1} = M φ̃_h + Q B â_h + Q (c − D φ̄), not over the local models' (`plan_term`): on the controlled check a
local model's ∂φ̂/∂a along a direction that moves little (a point's position, 0.05 per unit action) beside one
that moves much (a screen) had the wrong sign in nodes with few or noisy transitions, and the pull toward the
goal's screen value, which no plan can keep, outweighed the pull toward its position (docs/dual-system.md,
item 11). No action map (too few transitions): no pull.

Why a goal and not a field over the regions: a softmax field g(φ) = Σ_n softmax(−‖u − c_n‖²/2σ²)_n v_n (the
first design) is flat deep inside a region, so it pulls only within about e_max of a boundary, and its
gradient along latent directions no action moves outweighed the rest. On the controlled check with the true
aim (`core.dual.checks.planner_aim.machinery_check`, docs/dual-system.md) the goal kept the planner in the
learnable third far more than the field did.
"""

from __future__ import annotations

import copy

import numpy as np

from core.dual.action_map import ActionMap

SMOOTHING = 1e-3
"""ε of the pull's norm, in map units."""


class RegionGoal:
    """g(φ) and ∂g/∂φ from node positions ``centres [N, d]`` (map coordinates) and ``values [N]``."""

    def __init__(self, centres: np.ndarray, values: np.ndarray, unit: float | None = None,
                 action_map: ActionMap | None = None, adjacency: np.ndarray | None = None) -> None:
        self.action_map = action_map
        """The start node's linear dynamics, through which a plan's latents are predicted (None: no pull)."""
        self.centres = np.asarray(centres, dtype=np.float64)
        self.values = np.clip(np.asarray(values, dtype=np.float64).reshape(-1), 0.0, None)
        """v_n, each region's value (clipped at 0)."""
        count = self.values.shape[0]
        if self.centres.shape[0] != count:
            raise ValueError("one value per centre")
        links = np.zeros((count, count)) if adjacency is None else np.asarray(adjacency, dtype=np.float64)
        if links.shape != (count, count):
            raise ValueError(f"adjacency must be [{count}, {count}], got {links.shape}")
        average = (self.values + links @ self.values) / (1.0 + links.sum(axis=1))
        self.smoothed = np.minimum(self.values, average)
        """s_n, each value averaged with its map neighbours', capped at the node's own."""
        self.unit = 1.0 if unit is None else float(unit)
        contrast = float(self.smoothed.max() - self.smoothed.mean()) if count else 0.0
        self.weight = contrast if contrast > 0.0 else 0.0
        """w: the pull's length in u (0: no aim)."""
        peak = self.smoothed == self.smoothed.max() if count else np.zeros(0, dtype=bool)
        self.goal = self.centres[peak].mean(axis=0) if self.weight > 0.0 else None
        """ḡ in map coordinates, the mean of the tied peaks (None: no aim)."""
        self.babbled = False
        """Whether the goal was babbled past the map's edge (`redirected`), not the values' peak."""

    def redirected(self, goal: np.ndarray | None, weight: float | None = None) -> RegionGoal:
        """The same pull (action map, values; length ``weight``, else w) toward another point ``goal`` of the
        map's coordinates (`core.dual.goal_babbling`), or with no goal (None: no pull); ``self`` unchanged.
        A goal needs a positive length: redirecting an aim with no contrast needs ``weight``."""
        other = copy.copy(self)
        other.babbled = goal is not None
        dims = self.centres.shape[1]
        other.goal = None if goal is None else np.asarray(goal, dtype=np.float64).reshape(dims)
        other.weight = self.weight if weight is None else float(weight)
        if other.goal is not None and not other.weight > 0.0:
            raise ValueError(f"a goal needs a pull length > 0, got {other.weight}")
        return other

    def __call__(self, latents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """g of each row of ``latents [H, d]`` (``[H]``) and its gradient w.r.t. the latent (``[H, d]``)."""
        u = np.asarray(latents, dtype=np.float64).reshape(-1, self.centres.shape[1]) / self.unit
        if self.goal is None:
            return np.zeros(u.shape[0]), np.zeros_like(u)
        diff = u - self.goal
        distance = np.sqrt((diff * diff).sum(axis=1) + SMOOTHING**2)
        return -self.weight * distance, -self.weight * diff / distance[:, None] / self.unit

    def plan_term(self, phi: np.ndarray, plan: np.ndarray) -> tuple[float, np.ndarray]:
        """Σ_h g(φ̃_{h+1}) over the plan ``[H, action]`` from ``phi`` ``[d]``, φ̃ the latents the action map
        predicts (`ActionMap.rollout`), and its gradient w.r.t. the plan (`ActionMap.pull_back`); 0 and zeros
        without an action map or an aim."""
        if self.action_map is None or self.goal is None:
            return 0.0, np.zeros_like(plan)
        latents = self.action_map.rollout(phi, np.asarray(plan, dtype=np.float64))
        values, grads = self(latents)
        return float(values.sum()), self.action_map.pull_back(grads)
