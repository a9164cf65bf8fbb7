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
- ``target="absolute"`` (Eq. 5 as printed: the network outputs φ̂′) or ``"delta"`` (``dual.model_target``,
  not in the paper: φ̂′ = φ + M(φ, a), the network outputs the change, and the reward head starts at 0). The
  hidden layer spends its 20 units on the change rather than on copying φ through tanh (docs/dual-system.md,
  "World models").
- ``latent_scale`` s and ``latent_offset`` μ (``dual.model_space = normalised``, set by the owner): the
  network reads (φ − μ) / s and its latent head is in units of s (φ̂′ = φ + s·M for delta, μ + s·M for
  absolute), so what it has learnt, its initial outputs and Adam's step (about α per weight) are relative to
  the latent's spread, not to its units: an untrained encoder's latents move by 0.005 per step, a trained
  one's by 0.5, and a step of 1e-3 on raw outputs is a noise floor of a few 0.01 in latent units.
- ``termination=True`` (``dual.model_termination``, not in the paper): a third head, a logit of "this
  transition ended the episode", trained with binary cross-entropy beside Eq. 5 (its own output weights; the
  hidden layer is shared). Imagined transitions take their ``done`` flag from it. Eq. 8 errors never include
  it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import torch

from core.dual.capacity import grown_capacity

OutputActivation = Literal["linear", "released"]
NodeInit = Literal["fresh", "parent"]
ErrorNorm = Literal["squared", "l2"]
ModelTarget = Literal["absolute", "delta"]


@dataclass(frozen=True)
class ModelPrediction:
    """Predicted next latents ``[B, latent]``, rewards ``[B]`` and termination probabilities ``[B]``."""

    next_latent: torch.Tensor
    reward: torch.Tensor
    done: torch.Tensor
    """P(terminated) from the termination head; zeros when the bank has none."""


class ModelBank:
    """Stacked local world models, one per ITM node (Eq. 5), with a stacked per-node Adam.

    Storage: one float32 tensor ``theta [capacity, P]`` holds every node's parameters flattened
    (w1 ``[in, hidden]``, b1, wm ``[hidden, latent]``, bm, wr ``[hidden, 1]``, br); ``params[name]``
    are views of it. Adam's first/second moments are tensors of the same shape, so one Adam step over
    all touched nodes is a handful of tensor ops whatever the number of nodes.
    """

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
        target: ModelTarget = "absolute",
        termination: bool = False,
    ) -> None:
        if output_activation not in ("linear", "released"):
            raise ValueError(f"output_activation must be 'linear' or 'released', got {output_activation!r}")
        if init not in ("fresh", "parent"):
            raise ValueError(f"init must be 'fresh' or 'parent', got {init!r}")
        if error_norm not in ("squared", "l2"):
            raise ValueError(f"error_norm must be 'squared' or 'l2', got {error_norm!r}")
        if lr <= 0:
            raise ValueError(f"model lr must be > 0, got {lr}")
        if target not in ("absolute", "delta"):
            raise ValueError(f"model target must be 'absolute' or 'delta', got {target!r}")
        if target == "delta" and output_activation == "released":
            raise ValueError("a delta model needs linear outputs (a sigmoid output cannot be a change)")
        self.latent_dim = latent_dim
        self.action_dim = action_dim
        self.hidden = hidden
        self.lr = float(lr)
        self.beta1, self.beta2 = (float(b) for b in betas)
        self.eps = float(eps)
        self.output_activation: OutputActivation = output_activation
        self.init: NodeInit = init
        self.error_norm: ErrorNorm = error_norm
        self.target: ModelTarget = target
        self.termination = bool(termination)
        self.latent_scale = 1.0
        """s: the models read (φ − μ) / s and output changes (or latents) in units of s — set by the owner
        (``dual.model_space = normalised``: the latent's running RMS spread), 1 for the raw latent."""
        self.latent_offset = torch.zeros(latent_dim)
        """μ of the above (zeros for the raw latent)."""
        self.generator = generator if generator is not None else torch.Generator().manual_seed(0)
        in_dim = latent_dim + action_dim
        self._shapes: dict[str, tuple[int, ...]] = {
            "w1": (in_dim, hidden),
            "b1": (hidden,),
            "wm": (hidden, latent_dim),
            "bm": (latent_dim,),
            "wr": (hidden, 1),
            "br": (1,),
        }
        if self.termination:
            self._shapes.update({"wd": (hidden, 1), "bd": (1,)})
        self._slices: dict[str, slice] = {}
        offset = 0
        for k, shape in self._shapes.items():
            size = math.prod(shape)
            self._slices[k] = slice(offset, offset + size)
            offset += size
        self.num_params = offset
        capacity = max(1, int(initial_capacity))
        self.theta = torch.zeros((capacity, self.num_params))
        self.exp_avg = torch.zeros_like(self.theta)
        self.exp_avg_sq = torch.zeros_like(self.theta)
        self.steps = torch.zeros(capacity, dtype=torch.int64)
        self.reset_nodes(torch.arange(capacity))

    # ------------------------------------------------------------------ capacity and node events
    @property
    def capacity(self) -> int:
        return self.steps.shape[0]

    @property
    def params(self) -> dict[str, torch.Tensor]:
        """Named views ``[capacity, *shape]`` into ``theta`` (writes go through)."""
        return self._split(self.theta)

    def _split(self, flat: torch.Tensor) -> dict[str, torch.Tensor]:
        rows = flat.shape[0]
        return {k: flat[:, self._slices[k]].view(rows, *shape) for k, shape in self._shapes.items()}

    def ensure_capacity(self, size: int) -> None:
        """Grow the stacked tensors geometrically (×2) until ``size`` slots exist."""
        old = self.capacity
        if size <= old:
            return
        new = grown_capacity(old, size)
        extra = torch.zeros((new - old, self.num_params))
        self.theta = torch.cat([self.theta, extra])
        self.exp_avg = torch.cat([self.exp_avg, extra])
        self.exp_avg_sq = torch.cat([self.exp_avg_sq, extra])
        self.steps = torch.cat([self.steps, torch.zeros(new - old, dtype=torch.int64)])
        self.reset_nodes(torch.arange(old, new))

    def reset_nodes(
        self, node_ids: torch.Tensor | list[int], parents: torch.Tensor | list[int] | None = None
    ) -> None:
        """(Re)initialise the models of new ITM nodes ("fresh" or a copy of ``parents``), fresh Adam state."""
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        if ids.numel() == 0:
            return
        self.ensure_capacity(int(ids.max()) + 1)
        values = self._fresh(ids.numel())
        if self.init == "parent" and parents is not None:
            par = torch.as_tensor(parents, dtype=torch.int64).reshape(-1)
            valid = par >= 0
            values[valid] = self.theta[par[valid]]
        self.theta[ids] = values
        self.exp_avg[ids] = 0.0
        self.exp_avg_sq[ids] = 0.0
        self.steps[ids] = 0

    def _fresh(self, count: int) -> torch.Tensor:
        """``nn.Linear`` default init: weights and biases ~ U(−1/√fan_in, 1/√fan_in), flattened. A delta
        model's reward head starts at zero (r̂ = 0, as "nothing changes" predicts): a random reward output of
        ~0.5 would dominate Eq. 8 beside latent changes of 0.005 (an untrained encoder's) for many updates."""
        out = torch.empty((count, self.num_params))
        for k, sl in self._slices.items():
            fan_in = self.latent_dim + self.action_dim if k in ("w1", "b1") else self.hidden
            bound = 1.0 / math.sqrt(fan_in)
            uniform = torch.rand((count, sl.stop - sl.start), generator=self.generator)
            out[:, sl] = (uniform * 2.0 - 1.0) * bound
            if self.target == "delta" and k in ("wr", "br"):
                out[:, sl] = 0.0
        return out

    # ------------------------------------------------------------------ forward
    def _forward(
        self, p: dict[str, torch.Tensor], phi: torch.Tensor, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """Per-sample forward with per-sample parameters ``p[k]: [B, ...]``; returns (x, h, φ̂, r̂)."""
        x = torch.cat([self._model_input(phi), action], dim=-1)
        h = torch.tanh(torch.bmm(x.unsqueeze(1), p["w1"]).squeeze(1) + p["b1"])
        next_latent = torch.bmm(h.unsqueeze(1), p["wm"]).squeeze(1) + p["bm"]
        reward = (h * p["wr"].squeeze(-1)).sum(-1) + p["br"].squeeze(-1)
        if self.output_activation == "released":
            next_latent = torch.sigmoid(next_latent)
            reward = torch.tanh(reward)
        return x, h, self._model_output(phi, next_latent), reward

    def _model_input(self, phi: torch.Tensor) -> torch.Tensor:
        """(φ − μ) / s (φ itself for the raw latent)."""
        if self.latent_scale == 1.0 and not bool(self.latent_offset.any()):
            return phi
        return (phi - self.latent_offset) / self.latent_scale

    def _model_output(self, phi: torch.Tensor, output: torch.Tensor) -> torch.Tensor:
        """φ̂′ from the latent head's output: φ + s·output (delta) or μ + s·output (absolute)."""
        if self.latent_scale != 1.0 or bool(self.latent_offset.any()):
            output = output * self.latent_scale
            base = phi if self.target == "delta" else self.latent_offset
            return base + output
        return phi + output if self.target == "delta" else output

    def _done_logit(self, p: dict[str, torch.Tensor], h: torch.Tensor) -> torch.Tensor:
        """The termination head's logit ``[B]`` (zeros without a head)."""
        if not self.termination:
            return torch.zeros(h.shape[0])
        return (h * p["wd"].squeeze(-1)).sum(-1) + p["bd"].squeeze(-1)

    def gather(self, node_ids: torch.Tensor) -> dict[str, torch.Tensor]:
        """Parameters of the given nodes, one row per id (a gathered copy)."""
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        return self._split(self.theta.index_select(0, ids))

    def forward_with(
        self, params: dict[str, torch.Tensor], phi: torch.Tensor, action: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Differentiable forward with already gathered parameters (the planner's autograd reference)."""
        _, _, next_latent, reward = self._forward(params, phi, action)
        return next_latent, reward

    @torch.no_grad()
    def predict(self, node_ids: torch.Tensor, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        """M_n(φ, a) and R_n(φ, a) for each (node, sample) pair, one batched op."""
        phi, action = _as_batch(phi), _as_batch(action)
        params = self.gather(node_ids)
        _, h, next_latent, reward = self._forward(params, phi, action)
        done = torch.sigmoid(self._done_logit(params, h)) if self.termination else torch.zeros_like(reward)
        return ModelPrediction(next_latent=next_latent, reward=reward, done=done)

    @torch.no_grad()
    def predict_rows(self, rows: torch.Tensor, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        """Like `predict`, with explicit flattened parameter rows ``[B, num_params]`` (e.g. snapshots)."""
        params = self._split(rows)
        _, h, next_latent, reward = self._forward(params, _as_batch(phi), _as_batch(action))
        done = torch.sigmoid(self._done_logit(params, h)) if self.termination else torch.zeros_like(reward)
        return ModelPrediction(next_latent=next_latent, reward=reward, done=done)

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
    @torch.no_grad()
    def update(
        self,
        node_ids: torch.Tensor,
        phi: torch.Tensor,
        action: torch.Tensor,
        next_phi: torch.Tensor,
        reward: torch.Tensor,
        terminated: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """One Adam step per touched node on its mean Eq. 5 loss; returns pre-update Eq. 8 errors ``[B]``.

        Samples may share a node: each sample's loss is weighted by 1/(its node's sample count), the
        per-sample gradients (written out by hand for the one-hidden-layer model) are summed per node
        with ``index_add_``, and the Adam step is applied to the touched nodes' rows only, with each
        node's own step count in the bias correction. With a termination head its binary cross-entropy
        on ``terminated`` (zeros when None) is added to each sample's loss.
        """
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        phi, action = _as_batch(phi), _as_batch(action)
        next_phi = _as_batch(next_phi)
        reward = torch.as_tensor(reward, dtype=torch.float32).reshape(-1)
        if ids.numel() != phi.shape[0]:
            raise ValueError(f"update got {ids.numel()} node ids for {phi.shape[0]} samples")
        if bool((ids == ids[0]).all()):
            return self._update_one_node(int(ids[0]), phi, action, next_phi, reward, terminated)
        if ids.numel() == 1:
            unique, inverse, counts = ids, torch.zeros(1, dtype=torch.int64), torch.ones(1, dtype=torch.int64)
        else:
            unique, inverse, counts = torch.unique(ids, return_inverse=True, return_counts=True)
        rows = self.theta.index_select(0, unique)
        per_sample = self._split(rows.index_select(0, inverse))
        x, h, pred_latent, pred_reward = self._forward(per_sample, phi, action)
        d_latent = pred_latent - next_phi
        d_reward = pred_reward - reward
        if self.error_norm == "squared":
            errors = (d_latent * d_latent).sum(-1) + d_reward * d_reward
        else:
            errors = d_latent.norm(dim=-1) + d_reward.abs()
        # ∂/∂output of Σ_b w_b (‖φ̂_b − φ′_b‖² + (r̂_b − r_b)²), w_b = 1 / count(node of b).
        weight = (2.0 / counts[inverse].to(torch.float32)).unsqueeze(-1)
        g_latent = weight * d_latent * self.latent_scale  # φ̂′ = base + s·output
        g_reward = weight.squeeze(-1) * d_reward
        if self.output_activation == "released":
            g_latent = g_latent * pred_latent * (1.0 - pred_latent)
            g_reward = g_reward * (1.0 - pred_reward * pred_reward)
        g_hidden = torch.bmm(per_sample["wm"], g_latent.unsqueeze(-1)).squeeze(-1)
        g_hidden = g_hidden + g_reward.unsqueeze(-1) * per_sample["wr"].squeeze(-1)
        if self.termination:
            done = torch.zeros(ids.numel()) if terminated is None else _as_batch(terminated).reshape(-1)
            # ∂ BCE(sigmoid(z), y) / ∂z = sigmoid(z) − y, weighted like the squared terms (1 / count).
            g_done = (torch.sigmoid(self._done_logit(per_sample, h)) - done) * weight.squeeze(-1) * 0.5
            g_hidden = g_hidden + g_done.unsqueeze(-1) * per_sample["wd"].squeeze(-1)
        g_hidden = g_hidden * (1.0 - h * h)
        batch = ids.numel()
        grad = torch.empty((batch, self.num_params))
        grad[:, self._slices["w1"]] = (x.unsqueeze(-1) * g_hidden.unsqueeze(1)).reshape(batch, -1)
        grad[:, self._slices["b1"]] = g_hidden
        grad[:, self._slices["wm"]] = (h.unsqueeze(-1) * g_latent.unsqueeze(1)).reshape(batch, -1)
        grad[:, self._slices["bm"]] = g_latent
        grad[:, self._slices["wr"]] = h * g_reward.unsqueeze(-1)
        grad[:, self._slices["br"]] = g_reward.unsqueeze(-1)
        if self.termination:
            grad[:, self._slices["wd"]] = h * g_done.unsqueeze(-1)
            grad[:, self._slices["bd"]] = g_done.unsqueeze(-1)
        if batch > 1:  # sum the per-sample gradients of each node (rows follow ``unique``'s order)
            grad = torch.zeros((unique.numel(), self.num_params)).index_add_(0, inverse, grad)
        self._adam_step(unique, rows, grad)
        return errors

    def _update_one_node(
        self,
        node: int,
        phi: torch.Tensor,
        action: torch.Tensor,
        next_phi: torch.Tensor,
        reward: torch.Tensor,
        terminated: torch.Tensor | None,
    ) -> torch.Tensor:
        """`update` when every sample belongs to one node (the per-step case): plain matrix products with that
        node's parameters, the gradient of the mean loss summed by ``x.T @ g``; the same step as the general
        path."""
        unique = torch.tensor([node])
        rows = self.theta.index_select(0, unique)
        p = {k: v[0] for k, v in self._split(rows).items()}
        x = torch.cat([self._model_input(phi), action], dim=-1)
        h = torch.tanh(x @ p["w1"] + p["b1"])
        out_latent = h @ p["wm"] + p["bm"]
        out_reward = h @ p["wr"][:, 0] + p["br"][0]
        if self.output_activation == "released":
            pred_latent, pred_reward = torch.sigmoid(out_latent), torch.tanh(out_reward)
        else:
            pred_latent, pred_reward = out_latent, out_reward
        pred_latent = self._model_output(phi, pred_latent)
        d_latent = pred_latent - next_phi
        d_reward = pred_reward - reward
        if self.error_norm == "squared":
            errors = (d_latent * d_latent).sum(-1) + d_reward * d_reward
        else:
            errors = d_latent.norm(dim=-1) + d_reward.abs()
        weight = 2.0 / phi.shape[0]
        g_latent = weight * d_latent * self.latent_scale
        g_reward = weight * d_reward
        if self.output_activation == "released":
            g_latent = g_latent * pred_latent * (1.0 - pred_latent)
            g_reward = g_reward * (1.0 - pred_reward * pred_reward)
        g_hidden = g_latent @ p["wm"].T + g_reward.unsqueeze(-1) * p["wr"][:, 0]
        if self.termination:
            done = torch.zeros(phi.shape[0]) if terminated is None else _as_batch(terminated).reshape(-1)
            g_done = (torch.sigmoid(h @ p["wd"][:, 0] + p["bd"][0]) - done) * (weight * 0.5)
            g_hidden = g_hidden + g_done.unsqueeze(-1) * p["wd"][:, 0]
        g_hidden = g_hidden * (1.0 - h * h)
        grad = torch.empty((1, self.num_params))
        grad[0, self._slices["w1"]] = (x.T @ g_hidden).reshape(-1)
        grad[0, self._slices["b1"]] = g_hidden.sum(0)
        grad[0, self._slices["wm"]] = (h.T @ g_latent).reshape(-1)
        grad[0, self._slices["bm"]] = g_latent.sum(0)
        grad[0, self._slices["wr"]] = h.T @ g_reward
        grad[0, self._slices["br"]] = g_reward.sum()
        if self.termination:
            grad[0, self._slices["wd"]] = h.T @ g_done
            grad[0, self._slices["bd"]] = g_done.sum()
        self._adam_step(unique, rows, grad)
        return errors

    def _adam_step(self, unique: torch.Tensor, rows: torch.Tensor, grad: torch.Tensor) -> None:
        """``torch.optim.Adam`` (no weight decay, no amsgrad) on the stacked rows of ``unique``."""
        step = self.steps[unique] + 1
        self.steps[unique] = step
        stepf = step.to(torch.float64)
        bias1 = (1.0 - self.beta1**stepf).to(torch.float32).unsqueeze(-1)
        bias2_sqrt = torch.sqrt(1.0 - self.beta2**stepf).to(torch.float32).unsqueeze(-1)
        b1, b2 = self.beta1, self.beta2
        m = self.exp_avg.index_select(0, unique).mul_(b1).add_(grad, alpha=1.0 - b1)
        v = self.exp_avg_sq.index_select(0, unique).mul_(b2).addcmul_(grad, grad, value=1.0 - b2)
        denom = v.sqrt().div_(bias2_sqrt).add_(self.eps)
        self.theta.index_copy_(0, unique, rows.addcdiv_(m, denom.mul_(bias1 / self.lr), value=-1.0))
        self.exp_avg.index_copy_(0, unique, m)
        self.exp_avg_sq.index_copy_(0, unique, v)

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict[str, torch.Tensor]:
        return {
            "theta": self.theta.clone(),
            "exp_avg": self.exp_avg.clone(),
            "exp_avg_sq": self.exp_avg_sq.clone(),
            "steps": self.steps.clone(),
        }

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        if state["theta"].dim() != 2 or state["theta"].shape[1] != self.num_params:
            raise ValueError(
                f"model-bank checkpoint holds {tuple(state['theta'].shape)} parameters, "
                f"this bank needs [*, {self.num_params}]"
            )
        self.theta = state["theta"].clone()
        self.exp_avg = state["exp_avg"].clone()
        self.exp_avg_sq = state["exp_avg_sq"].clone()
        self.steps = state["steps"].clone()


def _as_batch(x: torch.Tensor) -> torch.Tensor:
    t = torch.as_tensor(x, dtype=torch.float32)
    return t.unsqueeze(0) if t.dim() == 1 else t
