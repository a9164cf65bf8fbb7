"""Per-region learning progress from a lagged copy of each local model, measured on the region's held-out
transitions and as a fraction of the lagged model's error: what the ``progress`` planner aims at
(``dual.planner = progress``, issue 50).

Each node keeps a lagged copy θ̄_n of its model's parameters, θ̄_n ← (1 − κ) θ̄_n + κ θ_n after every update of
the node (Polyak averaging, horizon 1/κ updates; γ-Progress, Kim et al., ICML 2020, arXiv:2007.07853). On
each real transition of node n, once the node holds `MIN_HELD` held-out transitions (`HeldOutReliability`'s
ring: every k-th transition of the node, never trained on), both models are scored on that ring with Eq. 8's
error: the paired drop d = ⟨e(θ̄_n) − e(θ_n)⟩ and the lagged model's mean error ē = ⟨e(θ̄_n)⟩. The node keeps
exponential means of both (rate β); its progress is their ratio, clipped to [0, 1] (`relative`): the share
of the lagged model's error that the current model has removed.

Why each part (docs/dual-system.md, "A planner that aims", items 5-12; ThreeRegions, tuning seeds):

- *paired on the same transitions*: the sample-to-sample spread cancels, so a model that has converged, or
  whose outcomes are noise around a learnt mean, scores about 0;
- *a fraction of the lagged error*, not an amount in units of the latent's spread: where the outcome is
  noise the models keep learning its mean slowly (noisy targets under SGD), a real but small drop beside
  an error that cannot fall below the noise; the ratio divides that irreducible error away. As an amount
  (the first reading, γ-Progress on fresh transitions in units of s) the noise third ranked first for
  thousands of steps and the planner spent 0.359 of its steps there against the random walk's 0.420; as a
  fraction on held-out transitions 0.214;
- *on the held-out ring* rather than on the fresh transition: a region the agent sits in improves on the
  detail it is currently visiting while it forgets the rest; the ring (the node's last 4 × 48 transitions,
  every 4th) scores the model on what the region holds, not on where the agent happens to be. On fresh
  transitions the fractional signal drew the planner to the middle third (learnable share of the second
  half 0.178 against 0.337 on the ring).

Cost: two forward passes of one model over at most 48 transitions per real step.
"""

from __future__ import annotations

import numpy as np
import torch

from core.dual.model_bank import ModelBank
from core.dual.reliability import HeldOutReliability

LAG_RATE = 0.02
"""κ: the lagged copy follows the model over about 50 of the node's updates."""
MEAN_RATE = 0.05
"""β: a node's drop and lagged error average its last ~20 scorings."""
MIN_HELD = 8
"""Held-out transitions a node needs before it is scored (until then its progress stays 0)."""


class LaggedProgress:
    """Fractional held-out progress per node of a `ModelBank` (module docstring)."""

    def __init__(self, bank: ModelBank, heldout: HeldOutReliability, lag_rate: float = LAG_RATE,
                 mean_rate: float = MEAN_RATE) -> None:
        self.bank, self.heldout = bank, heldout
        self.lag_rate, self.mean_rate = float(lag_rate), float(mean_rate)
        self.lagged = bank.theta.clone()
        capacity = bank.theta.shape[0]
        self.drop = np.zeros(capacity)
        """Exponential mean of the paired held-out drop ⟨e(θ̄) − e(θ)⟩."""
        self.lagged_error = np.zeros(capacity)
        """Exponential mean of the lagged model's held-out error ⟨e(θ̄)⟩."""

    def _grow(self) -> None:
        capacity = self.bank.theta.shape[0]
        old = self.lagged.shape[0]
        if capacity <= old:
            return
        self.lagged = torch.cat([self.lagged, self.bank.theta[old:].clone()])
        pad = np.zeros(capacity - old)
        self.drop = np.concatenate([self.drop, pad])
        self.lagged_error = np.concatenate([self.lagged_error, pad])

    def reset_nodes(self, nodes: list[int] | np.ndarray) -> None:
        """New or freed nodes: the lagged copy starts as the node's (new) model, no progress yet."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        if ids.size == 0:
            return
        self._grow()
        index = torch.from_numpy(ids)
        self.lagged[index] = self.bank.theta[index]
        self.drop[ids] = 0.0
        self.lagged_error[ids] = 0.0

    @torch.no_grad()
    def record(self, node: int) -> None:
        """One real transition of ``node`` (after its model's step, before the lagged copy follows): score
        the lagged and current models on the node's held-out ring and update the two means."""
        self._grow()
        phi, action, reward, next_phi = self.heldout.held(node)
        n = phi.shape[0]
        if n < MIN_HELD:
            return
        lagged = self.bank.predict_rows(self.lagged[node].unsqueeze(0).expand(n, -1), phi, action)
        current = self.bank.predict(torch.full((n,), node, dtype=torch.int64), phi, action)
        error_lagged = self.bank.errors(lagged.next_latent, lagged.reward, next_phi, reward)
        error_now = self.bank.errors(current.next_latent, current.reward, next_phi, reward)
        self.drop[node] += self.mean_rate * (float((error_lagged - error_now).mean()) - self.drop[node])
        self.lagged_error[node] += self.mean_rate * (float(error_lagged.mean()) - self.lagged_error[node])

    def after_update(self, nodes: list[int] | np.ndarray) -> None:
        """θ̄ ← (1 − κ) θ̄ + κ θ for the nodes whose models just took a step."""
        ids = torch.from_numpy(np.unique(np.asarray(nodes, dtype=np.int64).reshape(-1)))
        self._grow()
        self.lagged[ids] = torch.lerp(self.lagged[ids], self.bank.theta[ids], self.lag_rate)

    def relative(self, nodes: np.ndarray | list[int]) -> np.ndarray:
        """Each node's progress, the mean drop over the lagged model's mean error, clipped to [0, 1] (0 before
        the node is scored)."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self._grow()
        return np.clip(self.drop[ids] / np.maximum(self.lagged_error[ids], 1e-12), 0.0, 1.0)

    def state_dict(self) -> dict[str, torch.Tensor]:
        return {"lagged": self.lagged.clone(), "drop": torch.from_numpy(self.drop.copy()),
                "lagged_error": torch.from_numpy(self.lagged_error.copy())}

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self.lagged = state["lagged"].clone()
        self.drop = state["drop"].numpy().copy()
        self.lagged_error = state["lagged_error"].numpy().copy()
