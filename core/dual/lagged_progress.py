"""Per-region learning progress from a lagged copy of each local model (γ-Progress; Kim et al., ICML 2020,
arXiv:2007.07853): what the ``progress`` planner aims at (``dual.planner = progress``, issue 50).

Each node keeps a lagged copy θ̄_n of its model's parameters, θ̄_n ← (1 − κ) θ̄_n + κ θ_n after every update of
the node (Polyak averaging, horizon 1/κ updates). On each fresh real transition of node n, before the model
learns from it, the progress sample is the lagged model's Eq. 8 error minus the current model's, on that same
transition: e(θ̄_n) − e(θ_n). Being paired on one transition, a sample has mean about 0 where the outcome is
noise (both models predict its mean) and where the model has converged (θ̄ ≈ θ), and is positive while the
model improves. The node's progress is an exponential mean of its samples (rate β); the planner reads it in
units of the latent's RMS spread s (the unit the repaired r_int uses), clipped to [0, 1] (`relative`). Not
in units of the region's own no-change error: where almost nothing changes (a learnt, trivial region) that
error is tiny and the ratio blew up (measured on ThreeRegions: 0.5 in the trivial third against 0.002-0.08
in the learnable one).

Unlike the held-out verdict (`core.dual.reliability`), which needs two snapshots ``HeldOut.lag`` = 100
updates apart before it can say anything, this signal exists after a node's first few transitions, and costs
one extra forward pass of one model per real step.
"""

from __future__ import annotations

import numpy as np
import torch

from core.dual.model_bank import ModelBank

LAG_RATE = 0.02
"""κ: the lagged copy follows the model over about 50 of the node's updates."""
MEAN_RATE = 0.05
"""β: a node's progress and no-change error average its last ~20 transitions."""


class LaggedProgress:
    """γ-Progress per node of a `ModelBank` (module docstring)."""

    def __init__(self, bank: ModelBank, lag_rate: float = LAG_RATE, mean_rate: float = MEAN_RATE) -> None:
        self.bank = bank
        self.lag_rate, self.mean_rate = float(lag_rate), float(mean_rate)
        self.lagged = bank.theta.clone()
        capacity = bank.theta.shape[0]
        self.progress = np.zeros(capacity)
        self.count = np.zeros(capacity, dtype=np.int64)

    def _grow(self) -> None:
        capacity = self.bank.theta.shape[0]
        old = self.lagged.shape[0]
        if capacity <= old:
            return
        self.lagged = torch.cat([self.lagged, self.bank.theta[old:].clone()])
        pad = capacity - old
        self.progress = np.concatenate([self.progress, np.zeros(pad)])
        self.count = np.concatenate([self.count, np.zeros(pad, dtype=np.int64)])

    def reset_nodes(self, nodes: list[int] | np.ndarray) -> None:
        """New or freed nodes: the lagged copy starts as the node's (new) model, no progress yet."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        if ids.size == 0:
            return
        self._grow()
        index = torch.from_numpy(ids)
        self.lagged[index] = self.bank.theta[index]
        self.progress[ids] = 0.0
        self.count[ids] = 0

    @torch.no_grad()
    def record(self, node: int, error_now: float, phi: torch.Tensor, action: torch.Tensor, reward: float,
               next_phi: torch.Tensor) -> None:
        """One fresh transition of ``node`` (``error_now``: the current model's Eq. 8 error on it, before it
        learns from it): a progress sample."""
        self._grow()
        lagged = self.bank.predict_rows(self.lagged[node].unsqueeze(0), phi.reshape(1, -1),
                                        action.reshape(1, -1))
        target_reward = torch.tensor([float(reward)])
        error_lagged = float(self.bank.errors(lagged.next_latent, lagged.reward, next_phi.reshape(1, -1),
                                              target_reward)[0])
        rate = max(self.mean_rate, 1.0 / (self.count[node] + 1))  # a plain mean until 1/β samples
        self.progress[node] += rate * ((error_lagged - error_now) - self.progress[node])
        self.count[node] += 1

    def after_update(self, nodes: list[int] | np.ndarray) -> None:
        """θ̄ ← (1 − κ) θ̄ + κ θ for the nodes whose models just took a step."""
        ids = torch.from_numpy(np.unique(np.asarray(nodes, dtype=np.int64).reshape(-1)))
        self._grow()
        self.lagged[ids] = torch.lerp(self.lagged[ids], self.bank.theta[ids], self.lag_rate)

    def relative(self, nodes: np.ndarray | list[int], unit: float) -> np.ndarray:
        """Each node's progress in units of ``unit`` (the latent's spread, squared with squared errors),
        clipped to [0, 1] (0 before any sample)."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self._grow()
        return np.clip(self.progress[ids] / unit, 0.0, 1.0)

    def state_dict(self) -> dict[str, torch.Tensor]:
        return {"lagged": self.lagged.clone(), "progress": torch.from_numpy(self.progress.copy()),
                "count": torch.from_numpy(self.count.copy())}

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self.lagged = state["lagged"].clone()
        self.progress = state["progress"].numpy().copy()
        self.count = state["count"].numpy().copy()
