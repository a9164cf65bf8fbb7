"""The world-model bank: one local model pair M_n, R_n per ITM node, stacked (Sections 2.2, 2.3.1).

Each node n owns a network [φ, a] → 20 tanh hidden units → next latent (32) and reward (1)
(Section 4.1.1: one hidden layer of 20 tanh units and two output layers of 32 and 1 units),
trained on Eq. 5:

    L_model = ‖M_n(φ_t, a_t) − φ_{t+1}‖² + ‖R_n(φ_t, a_t) − r^ext_t‖².

All nodes' parameters live in stacked tensors ``[capacity, ...]`` so that `predict` and `update`
for any batch of (node, sample) pairs are one gather + ``bmm`` / ``einsum`` — never a Python loop
over nodes. Capacity doubles when a node id beyond it appears.

The per-node optimiser is Adam implemented on the stacked tensors (``exp_avg``, ``exp_avg_sq`` and
a per-node step count): every node touched by an update moves exactly as an independent
``torch.optim.Adam`` over that node's own parameters would, on the mean Eq. 5 loss over that node's
samples in the batch; untouched nodes and their moments do not change.

Options (see docs/dual-system.md):

- ``output_activation="linear"`` (paper Section 4.1.1) or ``"released"`` (authors' code: sigmoid
  next latent, tanh reward).
- ``init="fresh"`` (authors' code: a new node gets a freshly initialised model, PyTorch's
  ``nn.Linear`` default init) or ``"parent"`` (a copy of the parameters of the node it was connected
  to; the Adam moments and step count always start fresh).
- ``error_norm="squared"`` (Eq. 8 as printed: squared norms) or ``"l2"`` (authors' code: unsquared
  norms ‖M − φ′‖₂ + |R − r|). The prediction error of a sample is computed BEFORE its update and
  returned by `update`, ready for the learning-progress tracker.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import torch

OutputActivation = Literal["linear", "released"]
NodeInit = Literal["fresh", "parent"]
ErrorNorm = Literal["squared", "l2"]

_PARAM_NAMES = ("w1", "b1", "wm", "bm", "wr", "br")


@dataclass(frozen=True)
class ModelPrediction:
    """Predicted next latents ``[B, latent]`` and rewards ``[B]``."""

    next_latent: torch.Tensor
    reward: torch.Tensor


class ModelBank:
    """Stacked local world models, one per ITM node (Eq. 5), with a stacked per-node Adam."""

    def __init__(
        self,
        latent_dim: int = 32,
        action_dim: int = 1,
        hidden: int = 20,
        lr: float = 1e-3,
        betas: tuple[float, float] = (0.9, 0.999),
        eps: float = 1e-8,
        output_activation: OutputActivation = "linear",
        init: NodeInit = "fresh",
        error_norm: ErrorNorm = "squared",
        initial_capacity: int = 64,
        generator: torch.Generator | None = None,
    ) -> None:
        if output_activation not in ("linear", "released"):
            raise ValueError(f"output_activation must be 'linear' or 'released', got {output_activation!r}")
        if init not in ("fresh", "parent"):
            raise ValueError(f"init must be 'fresh' or 'parent', got {init!r}")
        if error_norm not in ("squared", "l2"):
            raise ValueError(f"error_norm must be 'squared' or 'l2', got {error_norm!r}")
        if lr <= 0:
            raise ValueError(f"model lr must be > 0, got {lr}")
        self.latent_dim = latent_dim
        self.action_dim = action_dim
        self.hidden = hidden
        self.lr = float(lr)
        self.beta1, self.beta2 = (float(b) for b in betas)
        self.eps = float(eps)
        self.output_activation: OutputActivation = output_activation
        self.init: NodeInit = init
        self.error_norm: ErrorNorm = error_norm
        self.generator = generator if generator is not None else torch.Generator().manual_seed(0)
        capacity = max(1, int(initial_capacity))
        in_dim = latent_dim + action_dim
        self._shapes = {
            "w1": (in_dim, hidden),
            "b1": (hidden,),
            "wm": (hidden, latent_dim),
            "bm": (latent_dim,),
            "wr": (hidden, 1),
            "br": (1,),
        }
        self.params: dict[str, torch.Tensor] = {
            k: torch.zeros((capacity, *s)) for k, s in self._shapes.items()
        }
        self.exp_avg = {k: torch.zeros_like(v) for k, v in self.params.items()}
        self.exp_avg_sq = {k: torch.zeros_like(v) for k, v in self.params.items()}
        self.steps = torch.zeros(capacity, dtype=torch.int64)
        self.reset_nodes(torch.arange(capacity))

    # ------------------------------------------------------------------ capacity and node events
    @property
    def capacity(self) -> int:
        return self.steps.shape[0]

    def ensure_capacity(self, size: int) -> None:
        """Grow the stacked tensors geometrically (×2) until ``size`` slots exist."""
        old = self.capacity
        if size <= old:
            return
        new = old
        while new < size:
            new *= 2
        extra = new - old
        for store in (self.params, self.exp_avg, self.exp_avg_sq):
            for k, v in store.items():
                store[k] = torch.cat([v, torch.zeros((extra, *v.shape[1:]))])
        self.steps = torch.cat([self.steps, torch.zeros(extra, dtype=torch.int64)])
        self.reset_nodes(torch.arange(old, new))

    def reset_nodes(
        self, node_ids: torch.Tensor | list[int], parents: torch.Tensor | list[int] | None = None
    ) -> None:
        """(Re)initialise the models of new ITM nodes ("fresh" or a copy of ``parents``), fresh Adam state."""
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        if ids.numel() == 0:
            return
        self.ensure_capacity(int(ids.max()) + 1)
        copy_parent = self.init == "parent" and parents is not None
        par = torch.as_tensor(parents, dtype=torch.int64).reshape(-1) if parents is not None else None
        for k, shape in self._shapes.items():
            if copy_parent and par is not None:
                valid = par >= 0
                fresh = self._fresh(k, int((~valid).sum()))
                values = torch.empty((ids.numel(), *shape))
                values[valid] = self.params[k][par[valid]]
                values[~valid] = fresh
            else:
                values = self._fresh(k, ids.numel())
            self.params[k][ids] = values
            self.exp_avg[k][ids] = 0.0
            self.exp_avg_sq[k][ids] = 0.0
        self.steps[ids] = 0

    def _fresh(self, name: str, count: int) -> torch.Tensor:
        """``nn.Linear`` default init: weights and biases ~ U(−1/√fan_in, 1/√fan_in)."""
        fan_in = self.latent_dim + self.action_dim if name in ("w1", "b1") else self.hidden
        bound = 1.0 / math.sqrt(fan_in)
        shape = (count, *self._shapes[name])
        return (torch.rand(shape, generator=self.generator) * 2.0 - 1.0) * bound

    # ------------------------------------------------------------------ forward
    def _forward(
        self, p: dict[str, torch.Tensor], phi: torch.Tensor, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Per-sample forward with per-sample gathered parameters ``p[k]: [B, ...]``."""
        x = torch.cat([phi, action], dim=-1)
        h = torch.tanh(torch.einsum("bi,bih->bh", x, p["w1"]) + p["b1"])
        next_latent = torch.einsum("bh,bho->bo", h, p["wm"]) + p["bm"]
        reward = torch.einsum("bh,bho->bo", h, p["wr"]).squeeze(-1) + p["br"].squeeze(-1)
        if self.output_activation == "released":
            next_latent = torch.sigmoid(next_latent)
            reward = torch.tanh(reward)
        return next_latent, reward

    def gather(self, node_ids: torch.Tensor) -> dict[str, torch.Tensor]:
        """Parameters of the given nodes, one row per id (a gathered copy)."""
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        return {k: v[ids] for k, v in self.params.items()}

    def forward_with(
        self, params: dict[str, torch.Tensor], phi: torch.Tensor, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Differentiable forward with already gathered parameters (used by the planner, Eq. 6-7)."""
        return self._forward(params, phi, action)

    @torch.no_grad()
    def predict(self, node_ids: torch.Tensor, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        """M_n(φ, a) and R_n(φ, a) for each (node, sample) pair, one batched op."""
        phi, action = _as_batch(phi), _as_batch(action)
        next_latent, reward = self._forward(self.gather(node_ids), phi, action)
        return ModelPrediction(next_latent=next_latent, reward=reward)

    # ------------------------------------------------------------------ Eq. 8 errors
    def errors(
        self,
        next_latent: torch.Tensor,
        reward: torch.Tensor,
        target_latent: torch.Tensor,
        target_reward: torch.Tensor,
    ) -> torch.Tensor:
        """Per-sample prediction error e^prd (Eq. 8): squared norms or unsquared L2 norms."""
        d_latent = next_latent - target_latent
        d_reward = reward - target_reward
        if self.error_norm == "squared":
            return (d_latent * d_latent).sum(-1) + d_reward * d_reward
        return d_latent.norm(dim=-1) + d_reward.abs()

    # ------------------------------------------------------------------ Eq. 5 update
    def update(
        self,
        node_ids: torch.Tensor,
        phi: torch.Tensor,
        action: torch.Tensor,
        next_phi: torch.Tensor,
        reward: torch.Tensor,
    ) -> torch.Tensor:
        """One Adam step per touched node on its mean Eq. 5 loss; returns pre-update Eq. 8 errors ``[B]``.

        Samples may share a node. Gradients are taken on the gathered rows of the unique touched
        nodes, so each node's gradient is exactly that of its own mean loss; the Adam step is applied
        to those rows only (bias correction with each node's own step count).
        """
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        phi, action = _as_batch(phi).detach(), _as_batch(action).detach()
        next_phi = _as_batch(next_phi).detach()
        reward = torch.as_tensor(reward, dtype=torch.float32).reshape(-1).detach()
        if ids.numel() != phi.shape[0]:
            raise ValueError(f"update got {ids.numel()} node ids for {phi.shape[0]} samples")
        unique, inverse, counts = torch.unique(ids, return_inverse=True, return_counts=True)
        leaves = {k: v[unique].requires_grad_(True) for k, v in self.params.items()}
        per_sample = {k: v[inverse] for k, v in leaves.items()}
        pred_latent, pred_reward = self._forward(per_sample, phi, action)
        d_latent = pred_latent - next_phi
        d_reward = pred_reward - reward
        sq = (d_latent * d_latent).sum(-1) + d_reward * d_reward
        weights = 1.0 / counts[inverse].to(sq.dtype)
        loss = (sq * weights).sum()
        grads = torch.autograd.grad(loss, list(leaves.values()))
        with torch.no_grad():
            errors = sq.detach() if self.error_norm == "squared" else d_latent.norm(dim=-1) + d_reward.abs()
            self._adam_step(unique, dict(zip(leaves.keys(), grads, strict=True)))
        return errors.detach()

    @torch.no_grad()
    def _adam_step(self, unique: torch.Tensor, grads: dict[str, torch.Tensor]) -> None:
        """``torch.optim.Adam`` (no weight decay, no amsgrad) on the stacked rows of ``unique``."""
        step = self.steps[unique] + 1
        self.steps[unique] = step
        stepf = step.to(torch.float64)
        bias1 = (1.0 - self.beta1**stepf).to(torch.float32)
        bias2_sqrt = torch.sqrt(1.0 - self.beta2**stepf).to(torch.float32)
        for k, g in grads.items():
            view = (-1,) + (1,) * (g.dim() - 1)
            m = self.exp_avg[k][unique].mul_(self.beta1).add_(g, alpha=1.0 - self.beta1)
            v = self.exp_avg_sq[k][unique].mul_(self.beta2).addcmul_(g, g, value=1.0 - self.beta2)
            denom = v.sqrt() / bias2_sqrt.view(view) + self.eps
            p = self.params[k][unique] - (self.lr / bias1).view(view) * m / denom
            self.exp_avg[k][unique] = m
            self.exp_avg_sq[k][unique] = v
            self.params[k][unique] = p

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict[str, torch.Tensor]:
        state = {f"param.{k}": v.clone() for k, v in self.params.items()}
        state |= {f"exp_avg.{k}": v.clone() for k, v in self.exp_avg.items()}
        state |= {f"exp_avg_sq.{k}": v.clone() for k, v in self.exp_avg_sq.items()}
        state["steps"] = self.steps.clone()
        return state

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        for k in _PARAM_NAMES:
            if tuple(state[f"param.{k}"].shape[1:]) != self._shapes[k]:
                raise ValueError(f"model-bank checkpoint: {k} has shape {tuple(state[f'param.{k}'].shape)}")
            self.params[k] = state[f"param.{k}"].clone()
            self.exp_avg[k] = state[f"exp_avg.{k}"].clone()
            self.exp_avg_sq[k] = state[f"exp_avg_sq.{k}"].clone()
        self.steps = state["steps"].clone()


def _as_batch(x: torch.Tensor) -> torch.Tensor:
    t = torch.as_tensor(x, dtype=torch.float32)
    return t.unsqueeze(0) if t.dim() == 1 else t
