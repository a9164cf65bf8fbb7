"""Per-region learning progress: how fast a local model's gain over the best action-free predictor of its
region grows, measured on the region's held-out transitions — what the ``progress`` planner aims at
(``dual.planner = progress``, issue 50).

Each node keeps a lagged copy θ̄_n of its model's parameters, θ̄_n ← (1 − κ) θ̄_n + κ θ_n after every update of
the node (Polyak averaging, horizon 1/κ updates; γ-Progress, Kim et al., ICML 2020, arXiv:2007.07853). On
each real transition of node n, once the node holds `MIN_HELD` held-out transitions (`HeldOutReliability`'s
ring: every k-th transition of the node, never trained on), three predictors are scored on that ring with
Eq. 8's error e: the current model θ_n, the lagged copy θ̄_n, and the **action-free baseline** — the least-
squares fit of [φ′, r] on [φ, 1] over the ring itself, e_base. Each model's gain is the share of the
baseline's error it removes, g(θ) = max(1 − e(θ) / e_base, 0), and the node's progress is the exponential
mean (rate β) of the gain's growth,

    LP_n = ⟨g(θ_n) − g(θ̄_n)⟩_β,   clipped to [0, 1] when read (`progress`).

Why each part (docs/dual-system.md, "A planner that aims", items 5-12 and 17; ThreeRegions, tuning seeds):

- *paired on the same transitions*: the sample-to-sample spread cancels, so a model that has converged
  scores about 0;
- *a gain over the action-free predictor*, not a drop of the error: where the outcome is noise around a
  mean, the models keep learning that mean slowly (noisy targets under SGD), a real drop of the error that
  the previous readings (the drop as an amount, then as a fraction of the lagged error) read as progress —
  on the controlled check the map grew first in the noise and its models, learning its mean, read 0.19-0.31
  in the first 2 000 steps, and the seeds whose planner went there failed (item 17, probe 8). The best
  predictor that ignores the action already knows that mean: a model gains on it only by what the action
  explains, so noise around a learnt mean scores 0 from the first scoring on, while a region whose
  dynamics the action drives gains as its model learns them. With this reading (probe 10) the planner's
  share of the learnable third over the second half rose above the random walk's by +0.28 and +0.29 on
  two sets of 20 tuning seeds (p = 0.004 each), and its share of the noise fell by 0.22 and 0.18;
- *on the held-out ring* rather than on the fresh transition: a region the agent sits in improves on the
  detail it is currently visiting while it forgets the rest; the ring (the node's last 4 × 48 transitions,
  every 4th) scores the model on what the region holds, not on where the agent happens to be.

Cost: two forward passes of one model and one least-squares fit over at most 48 transitions per real step.
"""

from __future__ import annotations

import numpy as np
import torch

from core.dual.model_bank import ModelBank
from core.dual.reliability import HeldOutReliability

LAG_RATE = 0.02
"""κ: the lagged copy follows the model over about 50 of the node's updates."""
MEAN_RATE = 0.05
"""β: a node's gain growth averages its last ~20 scorings."""
MIN_HELD = 8
"""Held-out transitions a node needs before it is scored (until then its progress stays 0)."""


class LaggedProgress:
    """Held-out gain growth per node of a `ModelBank` (module docstring)."""

    def __init__(self, bank: ModelBank, heldout: HeldOutReliability, lag_rate: float = LAG_RATE,
                 mean_rate: float = MEAN_RATE) -> None:
        self.bank, self.heldout = bank, heldout
        self.lag_rate, self.mean_rate = float(lag_rate), float(mean_rate)
        self.lagged = bank.theta.clone()
        capacity = bank.theta.shape[0]
        self.growth = np.zeros(capacity)
        """Exponential mean of the paired held-out gain growth ⟨g(θ) − g(θ̄)⟩."""

    def _grow(self) -> None:
        capacity = self.bank.theta.shape[0]
        old = self.lagged.shape[0]
        if capacity <= old:
            return
        self.lagged = torch.cat([self.lagged, self.bank.theta[old:].clone()])
        pad = np.zeros(capacity - old)
        self.growth = np.concatenate([self.growth, pad])

    def reset_nodes(self, nodes: list[int] | np.ndarray) -> None:
        """New or freed nodes: the lagged copy starts as the node's (new) model, no progress yet."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        if ids.size == 0:
            return
        self._grow()
        index = torch.from_numpy(ids)
        self.lagged[index] = self.bank.theta[index]
        self.growth[ids] = 0.0

    @torch.no_grad()
    def record(self, node: int) -> None:
        """One real transition of ``node`` (after its model's step, before the lagged copy follows): score
        the lagged and current models against the ring's action-free baseline and update the gain growth."""
        self._grow()
        phi, action, reward, next_phi = self.heldout.held(node)
        n = phi.shape[0]
        if n < MIN_HELD:
            return
        lagged = self.bank.predict_rows(self.lagged[node].unsqueeze(0).expand(n, -1), phi, action)
        current = self.bank.predict(torch.full((n,), node, dtype=torch.int64), phi, action)
        error_lagged = float(self.bank.errors(lagged.next_latent, lagged.reward, next_phi, reward).mean())
        error_now = float(self.bank.errors(current.next_latent, current.reward, next_phi, reward).mean())
        error_base = max(self.baseline_error(phi, reward, next_phi), 1e-12)
        gain_lagged = max(1.0 - error_lagged / error_base, 0.0)
        gain_now = max(1.0 - error_now / error_base, 0.0)
        self.growth[node] += self.mean_rate * ((gain_now - gain_lagged) - self.growth[node])

    def baseline_error(self, phi: torch.Tensor, reward: torch.Tensor, next_phi: torch.Tensor) -> float:
        """Mean Eq. 8 error e_base of the action-free predictor: [φ′, r] least-squares fitted on [φ, 1] over
        the given transitions (the ring) and scored on them."""
        n, d = phi.shape
        inputs = torch.cat([phi, torch.ones(n, 1, dtype=phi.dtype)], dim=1).double()
        targets = torch.cat([next_phi, reward.reshape(n, -1)], dim=1).double()
        coef = torch.linalg.lstsq(inputs, targets, driver="gelsd").solution
        fitted = (inputs @ coef).to(phi.dtype)
        errors = self.bank.errors(fitted[:, :d], fitted[:, d:].reshape(reward.shape), next_phi, reward)
        return float(errors.mean())

    def after_update(self, nodes: list[int] | np.ndarray) -> None:
        """θ̄ ← (1 − κ) θ̄ + κ θ for the nodes whose models just took a step."""
        ids = torch.from_numpy(np.unique(np.asarray(nodes, dtype=np.int64).reshape(-1)))
        self._grow()
        self.lagged[ids] = torch.lerp(self.lagged[ids], self.bank.theta[ids], self.lag_rate)

    def progress(self, nodes: np.ndarray | list[int]) -> np.ndarray:
        """Each node's progress LP_n, its mean gain growth clipped to [0, 1] (0 before the node is scored)."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self._grow()
        return np.clip(self.growth[ids], 0.0, 1.0)

    def state_dict(self) -> dict[str, torch.Tensor]:
        return {"lagged": self.lagged.clone(), "growth": torch.from_numpy(self.growth.copy())}

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self.lagged = state["lagged"].clone()
        self.growth = state["growth"].numpy().copy()
