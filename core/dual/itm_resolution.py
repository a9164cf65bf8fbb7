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
