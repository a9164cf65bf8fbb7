"""A scale-free ITM resolution: e_max relative to the spread of the encoder's recent latents.

The ITM creates a node when a latent lies farther than e_max from its best match (Section 2.3.1). e_max = 6 is
the released code's value for the authors' encoder; the latent scale of another encoder — or of the same
encoder as it trains — is different: ours starts with latent distances near 0.01 and grows to about 1.5
(`dualsys diagnose regions`, docs/results.md), so a fixed e_max = 6 leaves the map at its two initial nodes
and the "local" models are one global model. `RelativeResolution` keeps the paper's idea (regions of a chosen
resolution) and drops the unit: e_max = ρ · the median pairwise L2 distance of the last `window` latents,
refreshed every `every` states. Off by default (``dual.e_max_relative`` None); the ``paper`` profile keeps
the absolute e_max.
"""

from __future__ import annotations

import numpy as np
import torch


class RelativeResolution:
    """Tracks recent latents; `observe` returns a new e_max (as an L2 distance) every `every` states."""

    def __init__(self, rho: float, latent_dim: int, window: int = 256, every: int = 64) -> None:
        if rho <= 0:
            raise ValueError(f"relative e_max must be > 0, got {rho}")
        self.rho = float(rho)
        self.every = int(every)
        self._latents = np.zeros((window, latent_dim), dtype=np.float64)
        self._seen = 0
        self.current: float | None = None
        """The last e_max handed out (None before the first refresh)."""

    def observe(self, phi: np.ndarray | torch.Tensor) -> float | None:
        """Record φ; every `every` states return ρ · median pairwise distance of the window, else None."""
        vector = phi.detach().cpu().numpy() if isinstance(phi, torch.Tensor) else np.asarray(phi)
        self._latents[self._seen % len(self._latents)] = vector.reshape(-1)
        self._seen += 1
        if self._seen % self.every:
            return None
        filled = self._latents[: min(self._seen, len(self._latents))]
        diffs = filled[:, None, :] - filled[None, :, :]
        distances = np.sqrt(np.einsum("ijk,ijk->ij", diffs, diffs))
        upper = distances[np.triu_indices(len(filled), k=1)]
        scale = float(np.median(upper))
        if scale <= 0.0:
            return None
        self.current = self.rho * scale
        return self.current

    def state_dict(self) -> dict[str, torch.Tensor]:
        return {
            "latents": torch.from_numpy(self._latents.copy()),
            "seen": torch.tensor(self._seen),
            "current": torch.tensor(
                float("nan") if self.current is None else self.current, dtype=torch.float64
            ),
        }

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self._latents = state["latents"].numpy().astype(np.float64).copy()
        self._seen = int(state["seen"])
        current = float(state["current"])
        self.current = None if np.isnan(current) else current
