"""A scale-free ITM resolution: e_max relative to the spread of the encoder's recent latents.

The ITM creates a node when a latent lies farther than e_max from its best match (Section 2.3.1). e_max = 6 is
the released code's value for the authors' encoder; the latent scale of another encoder — or of the same
encoder as it trains — is different: ours starts with latent distances near 0.01 and grows to about 1.5
(`dualsys diagnose regions`, docs/results.md), so a fixed e_max = 6 leaves the map at its two initial nodes
and the "local" models are one global model. `RelativeResolution` keeps the paper's idea (regions of a chosen
resolution) and drops the unit: e_max = ρ · the median pairwise L2 distance among `sample` latents drawn from
the last `window` (2048) states, refreshed every `every` states. The window is long on purpose: consecutive
latents of one episode are close to each other, and a first version that used the last 256 latents measured
that within-episode spread and cut the map into 170 regions in 4000 steps (docs/results.md). Off by default
(``dual.e_max_relative`` None); the ``paper`` profile keeps the absolute e_max.
"""

from __future__ import annotations

import numpy as np
import torch

from core.modelfree.agent import generator_state, restore_generator


class RelativeResolution:
    """Tracks recent latents; `observe` returns a new e_max (as an L2 distance) every `every` states."""

    def __init__(
        self,
        rho: float,
        latent_dim: int,
        window: int = 2048,
        every: int = 256,
        sample: int = 256,
        seed: int = 0,
    ) -> None:
        if rho <= 0:
            raise ValueError(f"relative e_max must be > 0, got {rho}")
        self.rho = float(rho)
        self.every = int(every)
        self.sample = int(sample)
        self._rng = np.random.default_rng(seed)
        self._latents = np.zeros((window, latent_dim), dtype=np.float64)
        self._seen = 0
        self.current: float | None = None
        """The last e_max handed out (None before the first refresh)."""

    def observe(self, phi: np.ndarray | torch.Tensor) -> float | None:
        """Record φ; every `every` states return ρ · the median pairwise distance of a window sample."""
        vector = phi.detach().cpu().numpy() if isinstance(phi, torch.Tensor) else np.asarray(phi)
        self._latents[self._seen % len(self._latents)] = vector.reshape(-1)
        self._seen += 1
        if self._seen % self.every:
            return None
        filled = self._latents[: min(self._seen, len(self._latents))]
        if len(filled) > self.sample:
            filled = filled[self._rng.choice(len(filled), size=self.sample, replace=False)]
        diffs = filled[:, None, :] - filled[None, :, :]
        distances = np.sqrt(np.einsum("ijk,ijk->ij", diffs, diffs))
        upper = distances[np.triu_indices(len(filled), k=1)]
        scale = float(np.median(upper))
        if scale <= 0.0:
            return None
        self.current = self.rho * scale
        return self.current

    def state_dict(self) -> dict[str, torch.Tensor | str]:
        return {
            "latents": torch.from_numpy(self._latents.copy()),
            "seen": torch.tensor(self._seen),
            "rng": generator_state(self._rng),
            "current": torch.tensor(
                float("nan") if self.current is None else self.current, dtype=torch.float64
            ),
        }

    def load_state_dict(self, state: dict[str, torch.Tensor | str]) -> None:
        self._latents = state["latents"].numpy().astype(np.float64).copy()
        self._seen = int(state["seen"])
        restore_generator(self._rng, state["rng"])
        current = float(state["current"])
        self.current = None if np.isnan(current) else current


class LatentScale:
    """The running RMS spread of the latent, for an ITM in scale-free coordinates (``regions = repaired``).

    The spread sqrt(EMA of ‖φ − μ‖²) around the running mean μ (an EMA too), both with the bias correction of
    Adam's moments and a time constant of ``horizon`` states; s follows the spread up at once and down only
    with the time constant ``shrink_horizon``: an agent that dwells in one corner of its latent space makes
    the recent spread small, and a scale that followed it would cut that corner into ever more regions (each
    with a new model whose learning looks like progress). The map sees φ / s: multiplying every latent by
    k multiplies s by k, so the normalised stream, the nodes and e_max (in units of s) do not change. Pure
    scaling is how our encoder's latent drifts most (distances grow about 100× over training,
    docs/results.md); nodes left behind by any other drift stop winning and are pruned
    (``dual.region_prune_after``). ``warm`` says whether ``warmup`` states have been seen: before that the
    spread of the first few, strongly correlated latents is no scale, and the map is not placed yet.
    """

    def __init__(
        self, dim: int, horizon: int = 200, warmup: int = 100, shrink_horizon: int = 20_000
    ) -> None:
        self.rate = 1.0 / float(horizon)
        self.shrink = 1.0 - 1.0 / float(shrink_horizon)
        self.warmup = int(warmup)
        self._mean = np.zeros(dim, dtype=np.float64)
        self._square = 0.0
        self._weight = 0.0
        self._scale = 0.0
        self.seen = 0

    @property
    def scale(self) -> float:
        """s (1 before two latents have been seen)."""
        return self._scale if self.seen >= 2 and self._scale > 0.0 else 1.0

    def _spread(self) -> float:
        if self._weight <= 0.0 or self._square <= 0.0:
            return 0.0
        return float(np.sqrt(self._square / self._weight))

    @property
    def mean(self) -> np.ndarray:
        """μ, the running mean (zeros before any latent)."""
        return self._mean / self._weight if self._weight > 0.0 else np.zeros_like(self._mean)

    @property
    def warm(self) -> bool:
        return self.seen >= self.warmup

    def observe(self, phi: np.ndarray | torch.Tensor) -> None:
        x = phi.detach().cpu().numpy() if isinstance(phi, torch.Tensor) else np.asarray(phi)
        x = x.astype(np.float64).reshape(-1)
        keep = 1.0 - self.rate
        self._weight = keep * self._weight + self.rate
        self._mean = keep * self._mean + self.rate * x
        deviation = x - self._mean / self._weight
        self._square = keep * self._square + self.rate * float(deviation @ deviation)
        self.seen += 1
        spread = self._spread()
        self._scale = spread if not self.warm else max(spread, self._scale * self.shrink)

    def normalise(self, phi: np.ndarray | torch.Tensor) -> np.ndarray:
        """φ / s as float64 NumPy (any leading shape)."""
        x = phi.detach().cpu().numpy() if isinstance(phi, torch.Tensor) else np.asarray(phi)
        return x.astype(np.float64) / self.scale

    def state_dict(self) -> dict[str, torch.Tensor]:
        return {
            "mean": torch.from_numpy(self._mean.copy()),
            "square": torch.tensor(self._square, dtype=torch.float64),
            "weight": torch.tensor(self._weight, dtype=torch.float64),
            "scale": torch.tensor(self._scale, dtype=torch.float64),
            "seen": torch.tensor(self.seen),
        }

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self._mean = state["mean"].numpy().astype(np.float64).copy()
        self._square = float(state["square"])
        self._weight = float(state["weight"])
        self._scale = float(state["scale"])
        self.seen = int(state["seen"])
