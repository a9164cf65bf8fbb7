"""A smooth field over the latent built from one value per region: what the aiming planners seek.

The planner's aim (``dual.planner`` = ``progress`` or ``novelty``; `core.dual.readings.Planner.aim`) is a
value per ITM region — its learning progress, or its prediction error. Regions are Voronoi cells of the map's
nodes, so the value of the region a predicted latent falls in is piecewise constant: gradient MPC (Eq. 7)
could not follow it. `RegionField` softens it: with u(φ) the map's coordinates (φ, or φ / s with a normalised
map) and c_n the live nodes,

    g(φ) = Σ_n w_n(φ) v_n,   w(φ) = softmax_n(−‖u(φ) − c_n‖² / (2σ²)),   σ = e_max,

which is v_n deep inside region n and blends neighbours across a boundary; its gradient
∂g/∂u = −Σ_n w_n (v_n − g) (u − c_n) / σ² points toward regions of larger value. One call evaluates a whole
plan's latents at once (NumPy, no loop over nodes).
"""

from __future__ import annotations

import numpy as np


class RegionField:
    """g(φ) and ∂g/∂φ from node positions ``centres [N, d]`` (map coordinates) and ``values [N]``."""

    def __init__(self, centres: np.ndarray, values: np.ndarray, width: float,
                 unit: float | None = None) -> None:
        if width <= 0.0:
            raise ValueError(f"field width must be > 0, got {width}")
        self.centres = np.asarray(centres, dtype=np.float64)
        self.values = np.asarray(values, dtype=np.float64).reshape(-1)
        if self.centres.shape[0] != self.values.shape[0]:
            raise ValueError("one value per centre")
        self.width = float(width)
        self.unit = 1.0 if unit is None else float(unit)

    def __call__(self, latents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """g of each row of ``latents [H, d]`` (``[H]``) and its gradient w.r.t. the latent (``[H, d]``)."""
        u = np.asarray(latents, dtype=np.float64).reshape(-1, self.centres.shape[1]) / self.unit
        diff = u[:, None, :] - self.centres[None, :, :]
        logits = -(diff * diff).sum(axis=2) / (2.0 * self.width**2)
        logits -= logits.max(axis=1, keepdims=True)
        weights = np.exp(logits)
        weights /= weights.sum(axis=1, keepdims=True)
        g = weights @ self.values
        pull = weights * (self.values[None, :] - g[:, None])
        grad_u = -np.einsum("hn,hnd->hd", pull, diff) / self.width**2
        return g, grad_u / self.unit
