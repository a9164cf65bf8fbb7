"""Per-region ensemble disagreement: what the ``disagreement`` planner aims at (``dual.planner =
disagreement``; issue 50), the objective of Plan2Explore (Sekar et al., ICML 2020) and MAX (Shyam et al., ICML
2019) — aim at what the models are uncertain about — on the same planner, field and regions as the
``progress`` planner, so that the two differ only in "aim at uncertainty" against "aim at progress".

Each node has E = `MEMBERS` extra local models, independently initialised and trained on the node's real
transitions exactly as its main model is (one Eq. 5 Adam step per fresh transition). They live as E rows per
node of one `ModelBank` (row n·E + e), so all members of a node predict and learn in one batched operation.
On each fresh transition of node n, before the members learn from it, the disagreement sample is the variance
of their predicted φ̂′ across members, averaged over the latent's dimensions; the node's disagreement is an
exponential mean of its samples (rate β), read in units of s² (s the latent's RMS spread), clipped to
[0, 1] (`relative`). Where the outcome is noise the members all learn its mean and agree (the variance is
epistemic, not the noise's), unlike a model's prediction error.
"""

from __future__ import annotations

import numpy as np
import torch

from core.dual.capacity import grown_capacity
from core.dual.model_bank import ModelBank

MEMBERS = 5
"""E: ensemble members per region (Plan2Explore uses 10 one-step models; 5 is MAX's order of magnitude)."""
MEAN_RATE = 0.05
"""β: a node's disagreement averages its last ~20 transitions."""


class EnsembleDisagreement:
    """E member models per node of a world's bank and their per-node disagreement (module docstring)."""

    def __init__(self, like: ModelBank, members: int = MEMBERS, mean_rate: float = MEAN_RATE,
                 seed: int = 0) -> None:
        self.members, self.mean_rate = int(members), float(mean_rate)
        capacity = like.theta.shape[0]
        self.bank = ModelBank(latent_dim=like.latent_dim, action_dim=like.action_dim, hidden=like.hidden,
                              lr=like.lr, output_activation=like.output_activation, init="fresh",
                              error_norm=like.error_norm, initial_capacity=capacity * self.members,
                              generator=torch.Generator().manual_seed(seed), target=like.target)
        self.bank.reset_nodes(torch.arange(capacity * self.members))
        self.value = np.zeros(capacity)
        self.count = np.zeros(capacity, dtype=np.int64)

    def _rows(self, node: int) -> torch.Tensor:
        return torch.arange(node * self.members, (node + 1) * self.members)

    def _grow(self, node: int) -> None:
        if node < self.value.shape[0]:
            return
        pad = grown_capacity(self.value.shape[0], node + 1) - self.value.shape[0]
        self.value = np.concatenate([self.value, np.zeros(pad)])
        self.count = np.concatenate([self.count, np.zeros(pad, dtype=np.int64)])

    def reset_nodes(self, nodes: list[int] | np.ndarray) -> None:
        """New or freed nodes: fresh members, no disagreement recorded yet."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        if ids.size == 0:
            return
        self._grow(int(ids.max()))
        self.bank.reset_nodes(torch.cat([self._rows(int(n)) for n in ids]))
        self.value[ids] = 0.0
        self.count[ids] = 0

    def follow_scale(self, scale: float) -> None:
        """The members read and predict in the world's model units (``world_models = repaired``)."""
        self.bank.latent_scale = scale

    def record_and_learn(self, node: int, phi: torch.Tensor, action: torch.Tensor, reward: float,
                         next_phi: torch.Tensor) -> None:
        """One fresh transition of ``node``: the members' disagreement on it, then one Eq. 5 step each."""
        self._grow(node)
        rows = self._rows(node)
        e = self.members
        phi_e, action_e = phi.reshape(1, -1).repeat(e, 1), action.reshape(1, -1).repeat(e, 1)
        with torch.no_grad():
            prediction = self.bank.predict(rows, phi_e, action_e)
        sample = float(prediction.next_latent.var(dim=0, unbiased=False).mean())
        rate = max(self.mean_rate, 1.0 / (self.count[node] + 1))  # a plain mean until 1/β samples
        self.value[node] += rate * (sample - self.value[node])
        self.count[node] += 1
        self.bank.update(rows, phi_e, action_e, next_phi.reshape(1, -1).repeat(e, 1),
                         torch.full((e,), float(reward)))

    def relative(self, nodes: np.ndarray | list[int], unit: float) -> np.ndarray:
        """Each node's disagreement in units of ``unit``² (the latent's spread), clipped to [0, 1]."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self._grow(int(ids.max()) if ids.size else 0)
        return np.clip(self.value[ids] / unit**2, 0.0, 1.0)

    def state_dict(self) -> dict[str, object]:
        return {"bank": self.bank.state_dict(), "value": torch.from_numpy(self.value.copy()),
                "count": torch.from_numpy(self.count.copy())}

    def load_state_dict(self, state: dict) -> None:
        self.bank.load_state_dict(state["bank"])
        self.value = state["value"].numpy().copy()
        self.count = state["count"].numpy().copy()
