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
- ``target="absolute"`` (Eq. 5 as printed: the network outputs φ̂′) or ``"delta"`` (``dual.world_models =
  repaired``, not in the paper: φ̂′ = φ + M(φ, a), the network outputs the change, and the reward head starts
  at 0). The hidden layer spends its 20 units on the change rather than on copying φ through tanh
  (docs/dual-system.md, "World models").
- ``latent_scale`` s and ``latent_offset`` μ (``dual.world_models = repaired``, set by the owner): the
  network reads (φ − μ) / s and its latent head is in units of s (φ̂′ = φ + s·M for delta, μ + s·M for
  absolute), so what it has learnt, its initial outputs and Adam's step (about α per weight) are relative to
  the latent's spread, not to its units: an untrained encoder's latents move by 0.005 per step, a trained
  one's by 0.5, and a step of 1e-3 on raw outputs is a noise floor of a few 0.01 in latent units.
- ``termination=True`` (``dual.imagination = repaired``, not in the paper): a third head, a logit of "this
  transition ended the episode", trained with binary cross-entropy beside Eq. 5 (its own output weights; the
  hidden layer is shared). Imagined transitions take their ``done`` flag from it. Eq. 8 errors never include
  it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np
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
        (``dual.world_models = repaired``: the latent's running RMS spread), 1 for the raw latent."""
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
    @property
    def local_model(self) -> LocalModel:
        """The nodes' network as a function of their parameters, in the bank's current unit (s, μ)."""
        return LocalModel(released=self.output_activation == "released", delta=self.target == "delta",
                          scale=self.latent_scale, offset=self.latent_offset)

    def gather(self, node_ids: torch.Tensor) -> dict[str, torch.Tensor]:
        """Parameters of the given nodes, one row per id (a gathered copy)."""
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        return self._split(self.theta.index_select(0, ids))

    @torch.no_grad()
    def predict(self, node_ids: torch.Tensor, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        """M_n(φ, a) and R_n(φ, a) for each (node, sample) pair, one batched op."""
        return self._predict(self.gather(node_ids), _as_batch(phi), _as_batch(action))

    @torch.no_grad()
    def predict_rows(self, rows: torch.Tensor, phi: torch.Tensor, action: torch.Tensor) -> ModelPrediction:
        """Like `predict`, with explicit flattened parameter rows ``[B, num_params]`` (e.g. snapshots)."""
        return self._predict(self._split(rows), _as_batch(phi), _as_batch(action))

    def _predict(self, params: dict[str, torch.Tensor], phi: torch.Tensor, action: torch.Tensor
                 ) -> ModelPrediction:
        out = self.local_model.forward(params, phi, action)
        done = torch.sigmoid(out.done_logit) if self.termination else torch.zeros_like(out.reward)
        return ModelPrediction(next_latent=out.latent, reward=out.reward, done=done)

    # ------------------------------------------------------------------ Eq. 8 errors
    def errors(
        self,
        next_latent: torch.Tensor,
        reward: torch.Tensor,
        target_latent: torch.Tensor,
        target_reward: torch.Tensor,
    ) -> torch.Tensor:
        """Per-sample prediction error e^prd (Eq. 8): squared norms or unsquared L2 norms."""
        return self._error(next_latent - target_latent, reward - target_reward)

    def _error(self, d_latent: torch.Tensor, d_reward: torch.Tensor) -> torch.Tensor:
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
        per-sample gradients (`LocalModel`'s chain rule, written out by hand for the one-hidden-layer model)
        are summed per node with ``index_add_``, and the Adam step is applied to the touched nodes' rows
        only, with each node's own step count in the bias correction. When every sample belongs to one node
        (the per-step case) the node's parameters are shared by the rows: plain matrix products, the sum
        over the samples inside them. With a termination head its binary cross-entropy on ``terminated``
        (zeros when None) is added to each sample's loss.
        """
        ids = torch.as_tensor(node_ids, dtype=torch.int64).reshape(-1)
        phi, action = _as_batch(phi), _as_batch(action)
        next_phi = _as_batch(next_phi)
        reward = torch.as_tensor(reward, dtype=torch.float32).reshape(-1)
        if ids.numel() != phi.shape[0]:
            raise ValueError(f"update got {ids.numel()} node ids for {phi.shape[0]} samples")
        one_node = bool((ids == ids[0]).all())
        if one_node:
            unique = ids[:1]
            rows = self.theta.index_select(0, unique)
            params = {k: v[0] for k, v in self._split(rows).items()}
            weight = weight_col = 2.0 / phi.shape[0]
        else:
            unique, inverse, counts = torch.unique(ids, return_inverse=True, return_counts=True)
            rows = self.theta.index_select(0, unique)
            params = self._split(rows.index_select(0, inverse))
            weight_col = (2.0 / counts[inverse].to(torch.float32)).unsqueeze(-1)
            weight = weight_col.squeeze(-1)
        model = self.local_model
        out = model.forward(params, phi, action)
        d_latent = out.latent - next_phi
        d_reward = out.reward - reward
        errors = self._error(d_latent, d_reward)
        # ∂/∂output of Σ_b w_b (‖φ̂_b − φ′_b‖² + (r̂_b − r_b)²), w_b = 1 / count(node of b).
        g_output = weight_col * d_latent * self.latent_scale  # φ̂′ = base + s·output
        g_reward = weight * d_reward
        if self.output_activation == "released":
            g_output = g_output * out.output * (1.0 - out.output)
            g_reward = g_reward * (1.0 - out.reward * out.reward)
        g_done = None
        if self.termination:
            done = torch.zeros(ids.numel()) if terminated is None else _as_batch(terminated).reshape(-1)
            # ∂ BCE(sigmoid(z), y) / ∂z = sigmoid(z) − y, weighted like the squared terms (1 / count).
            g_done = (torch.sigmoid(out.done_logit) - done) * weight * 0.5
        g_hidden = model.hidden_grad(params, out, g_output, g_reward, g_done)
        grads = model.param_grads(out, g_output, g_reward, g_done, g_hidden, per_sample=not one_node)
        n_rows = 1 if one_node else ids.numel()
        grad = torch.empty((n_rows, self.num_params))
        for k, value in grads.items():
            grad[:, self._slices[k]] = value.reshape(n_rows, -1)
        if not one_node:  # sum the per-sample gradients of each node (rows follow ``unique``'s order)
            grad = torch.zeros((unique.numel(), self.num_params)).index_add_(0, inverse, grad)
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


# ---------------------------------------------------------------------------------------------- the kernel
Array = Any
"""A float32 ``torch.Tensor`` (the bank) or a float64 NumPy array (the planner)."""


@dataclass(frozen=True)
class LocalPass:
    """One forward pass of `LocalModel.forward`, kept for its chain rule."""

    x: Array
    """The network's input [(φ − μ)/s, a]."""
    hidden: Array
    """tanh hidden units h."""
    output: Array
    """The latent head's output after its activation, before φ̂′ is formed from it (sigmoid(·) if released)."""
    latent: Array
    """φ̂′ (``output`` mapped back to latent units)."""
    reward: Array
    """r̂ (tanh(·) if released)."""
    done_logit: Array | None
    """The termination head's logit (None without a head)."""


@dataclass(frozen=True)
class LocalModel:
    """The local world model of an ITM node as a pure function of its parameters: the one forward pass and the
    one chain rule used by `ModelBank` (predictions and the Eq. 5 update) and by the planner (Eq. 6-7).

    [φ, a] → 20 tanh → φ̂′ (latent head), r̂ (reward head) and, with ``wd``/``bd`` among the parameters, a
    termination logit (Section 4.1.1; the options are those of the module docstring). The model reads
    x = [(φ − μ)/s, a] and forms φ̂′ = φ + s·M (delta) or μ + s·M (absolute) from its latent head M.

    Parameters ``p`` come in one of two layouts, and the same code serves both:

    - per sample: ``p[k]`` is ``[B, *shape]`` (each sample its own node's model; batched products ``bmm``);
    - shared: ``p[k]`` is ``shape`` (one model for every row of φ, or for a single unbatched φ; plain
      matrix products).

    Arrays are float32 tensors (the bank) or float64 NumPy arrays (the planner: `numpy`).
    """

    released: bool
    """Sigmoid next latent and tanh reward (the authors' code) instead of linear outputs."""
    delta: bool
    """φ̂′ = φ + s·M (``target="delta"``) instead of μ + s·M."""
    scale: float
    """s."""
    offset: Array
    """μ ``[latent]``."""

    def numpy(self) -> LocalModel:
        """The same model for float64 NumPy arrays (the planner's)."""
        return replace(self, scale=float(self.scale), offset=self.offset.double().numpy())

    def _unit(self) -> bool:
        """s = 1 and μ = 0: the model reads and writes latents as they are."""
        return self.scale == 1.0 and not bool(self.offset.any())

    def forward(self, p: dict[str, Array], phi: Array, action: Array) -> LocalPass:
        """M_n(φ, a), R_n(φ, a) and the termination logit, for either parameter layout."""
        unit = self._unit()
        x = _cat(phi if unit else (phi - self.offset) / self.scale, action)
        hidden = _tanh(_affine(x, p["w1"], p["b1"]))
        output = _affine(hidden, p["wm"], p["bm"])
        reward = _scalar_head(hidden, p["wr"], p["br"])
        if self.released:
            output, reward = _sigmoid(output), _tanh(reward)
        if unit:
            latent = phi + output if self.delta else output
        else:
            latent = (phi if self.delta else self.offset) + output * self.scale
        done = _scalar_head(hidden, p["wd"], p["bd"]) if "wd" in p else None
        return LocalPass(x=x, hidden=hidden, output=output, latent=latent, reward=reward, done_logit=done)

    @staticmethod
    def hidden_grad(
        p: dict[str, Array], out: LocalPass, g_output: Array, g_reward: Array, g_done: Array | None = None
    ) -> Array:
        """∂L/∂(pre-tanh hidden units) from the gradients w.r.t. the heads' pre-activation outputs."""
        g = _through(g_output, p["wm"]) + _col(g_reward) * p["wr"][..., 0]
        if g_done is not None:
            g = g + _col(g_done) * p["wd"][..., 0]
        return g * (1.0 - out.hidden * out.hidden)

    @staticmethod
    def input_grad(p: dict[str, Array], g_hidden: Array) -> Array:
        """∂L/∂x, x = [(φ − μ)/s, a], from `hidden_grad` (the planner's gradient w.r.t. its actions)."""
        return _through(g_hidden, p["w1"])

    @staticmethod
    def param_grads(
        out: LocalPass, g_output: Array, g_reward: Array, g_done: Array | None, g_hidden: Array,
        per_sample: bool,
    ) -> dict[str, Array]:
        """∂L/∂θ from the pre-activation gradients: per sample ``[B, ...]`` or summed over the rows."""
        grads = {
            "w1": _weight_grad(out.x, g_hidden, per_sample), "b1": _bias_grad(g_hidden, per_sample),
            "wm": _weight_grad(out.hidden, g_output, per_sample), "bm": _bias_grad(g_output, per_sample),
            "wr": _weight_grad(out.hidden, g_reward, per_sample), "br": _bias_grad(g_reward, per_sample),
        }
        if g_done is not None:
            grads["wd"] = _weight_grad(out.hidden, g_done, per_sample)
            grads["bd"] = _bias_grad(g_done, per_sample)
        return grads


def _affine(x: Array, w: Array, b: Array) -> Array:
    """x·W + b: one product per sample (per-sample W ``[B, in, out]``) or one matrix product (shared W)."""
    if w.ndim == 3:
        return torch.bmm(x.unsqueeze(1), w).squeeze(1) + b
    return x @ w + b


def _scalar_head(hidden: Array, w: Array, b: Array) -> Array:
    """A one-unit head (reward, termination logit): h·w + b ``[B]`` (or a scalar for an unbatched h)."""
    if w.ndim == 3:
        return (hidden * w[..., 0]).sum(-1) + b[..., 0]
    return hidden @ w[..., 0] + b[..., 0]


def _through(g: Array, w: Array) -> Array:
    """A gradient back through the weights W of x·W: g·Wᵀ (per sample or shared)."""
    if w.ndim == 3:
        return torch.bmm(w, g.unsqueeze(-1)).squeeze(-1)
    return g @ w.T


def _weight_grad(x: Array, g: Array, per_sample: bool) -> Array:
    """∂L/∂W of x·W: the outer product x ⊗ g per sample, or xᵀg summed over the rows."""
    if not per_sample:
        return x.T @ g
    return x.unsqueeze(-1) * g.unsqueeze(1) if g.ndim == 2 else x * g.unsqueeze(-1)


def _bias_grad(g: Array, per_sample: bool) -> Array:
    if not per_sample:
        return g.sum(0)
    return g if g.ndim == 2 else g.unsqueeze(-1)


def _col(g: Array) -> Array:
    """A per-row scalar as a column (a NumPy scalar stays one)."""
    return g.unsqueeze(-1) if isinstance(g, torch.Tensor) else g


def _cat(a: Array, b: Array) -> Array:
    return torch.cat([a, b], dim=-1) if isinstance(a, torch.Tensor) else np.concatenate([a, b], axis=-1)


def _tanh(x: Array) -> Array:
    return torch.tanh(x) if isinstance(x, torch.Tensor) else np.tanh(x)


def _sigmoid(x: Array) -> Array:
    return torch.sigmoid(x) if isinstance(x, torch.Tensor) else 1.0 / (1.0 + np.exp(-x))
