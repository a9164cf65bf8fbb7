"""Held-out reliability of the local world models: the repair of Eq. 8-9's learning progress as a
reliability signal (Section 2.3.2) and as the source of the intrinsic reward (``dual.reliability = heldout``).

The paper defines a region's reliability by the average prediction error of its model and uses the change
of that average, LP = ⟨e⟩_{t−W} − ⟨e⟩_t (Eq. 9), both for arbitration (LP ≥ 0 → model-based) and for
r_int = −LP. Measured on the stream of errors of new transitions, each window mean mixes the model's change
with the difference between the samples it happened to see: with σ = 40, W = 20 and 50 % per-sample noise,
P(LP ≥ 0) is 0.51 when the error halves over a run and 0.47 when it doubles (docs/dual-system.md). The repair
keeps both ideas — reliability from prediction error, progress as its change — and measures them with less
noise:

- every ``every``-th real transition of a node goes to the node's **held-out set** (a ring of ``size``) and is
  never trained on;
- the node's parameters are **snapshotted** every ``lag`` (L) real updates into a ring of `SNAPSHOTS`; the
  progress is the *paired* difference, on the same held-out samples, between the error of the snapshot
  taken one rotation before the newest (between L and 2L updates old) and the error of the current model:
  the sample-to-sample spread cancels. The oldest snapshot in the ring (up to `SNAPSHOTS` · L updates old)
  is compared too, since a slow change is significant only over a longer span. Both are undefined until
  two snapshots exist, i.e. for the first 2L updates of a node, so a young model is never "improving"
  merely for having left its random initialisation;
- the current model's held-out error is compared with the **no-change predictor** (φ̂′ = φ, r̂ = 0) on the same
  samples, which makes the figures scale-free: ``ratio`` = model error / no-change error.

`judge` is the verdict (a pure function, so the synthetic checks of `core.dual.checks.reliability` run the
very rule the agents use): with n ≥ ``size`` / 2 held-out samples, the paired mean difference d̄ and its
standard error s,

- improving = d̄ > z·s and ratio < 1 (the model gets better and already beats "nothing changes");
- worsening = d̄ < −z·s;
- accurate = ratio ≤ ``accurate_ratio``;
- trusted = improving, or accurate and not worsening.

A region whose model cannot learn (random outcomes) has a ratio that stays above the accurate level and no
progress beyond its standard error, so it is not trusted. The progress d̄ itself (`progress_of`, in error
units) is what the repaired intrinsic reward uses (`LocalWorldModels.intrinsic_reward`); ``share`` =
clip(1 − ratio, 0, 1) gates imagination. All per-node state is stacked ``[capacity, ...]`` and `evaluate`
handles any set of nodes in one batched forward of the bank (gather + ``bmm``), never a loop over nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from core.dual.capacity import grown_capacity
from core.dual.model_bank import ModelBank

EVALUATE_EVERY = 4
"""A node is re-judged every this many of its real updates (and whenever `evaluate` is called)."""

SNAPSHOTS = 4
"""Parameter snapshots kept per node (one every L updates): comparisons reach L..2L and up to 4L back."""


def share_from_ratio(ratio: np.ndarray | float, max_ratio: float = 1.0) -> np.ndarray:
    """clip(1 − ratio / max_ratio, 0, 1): how much better than "nothing changes" a model is
    (``imagination_gate``); no transition is kept from a model at or above ``max_ratio`` of the no-change
    error (``dual.imagination_max_ratio``)."""
    return np.clip(1.0 - np.asarray(ratio, dtype=np.float64) / max_ratio, 0.0, 1.0)


@dataclass(frozen=True)
class Verdict:
    """`judge`'s figures per node (arrays ``[k]``)."""

    trusted: np.ndarray
    ratio: np.ndarray
    """Mean held-out error of the current model / that of the no-change predictor (NaN: undefined)."""
    progress: np.ndarray
    """Paired mean error decrease since the recent snapshot, in error units (0: undefined)."""
    standard_error: np.ndarray
    """Standard error of that paired mean, in the same units (0: undefined)."""


def _paired(
    before: np.ndarray, now: np.ndarray, mask: np.ndarray, count: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard error of the per-sample error decrease ``before − now`` over the filled slots."""
    safe = np.maximum(count, 1)
    diff = np.where(mask, before - now, 0.0)
    mean = diff.sum(axis=1) / safe
    spread = np.where(mask, diff - mean[:, None], 0.0)
    variance = (spread * spread).sum(axis=1) / np.maximum(count - 1, 1)
    return mean, np.sqrt(variance / safe)


def judge(
    error_now: np.ndarray,
    error_before: np.ndarray | list[np.ndarray],
    error_no_change: np.ndarray,
    mask: np.ndarray,
    z: float,
    accurate_ratio: float,
    min_count: int,
    comparable: np.ndarray | None = None,
    recent: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> Verdict:
    """The reliability verdict for k nodes from their held-out errors ``[k, n]`` (``mask``: filled slots).

    ``error_now``: the current model; ``error_before``: one snapshot's errors, or a list of them (the first is
    the recent snapshot whose difference is the reported progress, the others older ones — a slow change is
    significant over a longer span); ``error_no_change``: φ̂′ = φ, r̂ = 0. ``comparable`` (default all) marks
    the nodes whose snapshots exist; elsewhere progress is undefined: neither improving nor worsening,
    progress 0. Improving: any snapshot's difference exceeds z standard errors (and ratio < 1); worsening:
    any falls below −z standard errors. ``recent`` = (model errors, no-change errors, mask), each
    ``[k, w]``: when given, the ratio is taken over these (the newest transitions, each scored before the
    model learnt from it) instead of the held-out set, and needs ``min_count`` of them. See the module
    docstring for the rule.
    """
    befores = error_before if isinstance(error_before, list) else [error_before]
    mask = mask.astype(bool)
    count = mask.sum(axis=1)
    safe = np.maximum(count, 1)
    now = np.where(mask, error_now, 0.0).sum(axis=1) / safe
    no_change = np.where(mask, error_no_change, 0.0).sum(axis=1) / safe
    enough = count >= max(2, min_count)
    paired = enough if comparable is None else enough & comparable
    if recent is not None:
        recent_mask = recent[2].astype(bool)
        recent_count = recent_mask.sum(axis=1)
        now = np.where(recent_mask, recent[0], 0.0).sum(axis=1) / np.maximum(recent_count, 1)
        no_change = np.where(recent_mask, recent[1], 0.0).sum(axis=1) / np.maximum(recent_count, 1)
        enough = recent_count >= max(2, min_count)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(no_change > 0, now / no_change, np.where(now > 0, np.inf, 0.0))
    improving = np.zeros(count.shape, dtype=bool)
    worsening = np.zeros(count.shape, dtype=bool)
    progress = standard_error = np.zeros(count.shape)
    for index, before in enumerate(befores):
        mean, se = _paired(before, error_now, mask, count)
        improving |= (mean > z * se) & (mean > 0)
        worsening |= mean < -z * se
        if index == 0:
            progress, standard_error = mean, se
    improving &= paired & (ratio < 1.0)
    worsening &= paired
    accurate = ratio <= accurate_ratio
    trusted = enough & (improving | (accurate & ~worsening))
    return Verdict(
        trusted=trusted,
        ratio=np.where(enough, ratio, np.nan),
        progress=np.where(paired, progress, 0.0),
        standard_error=np.where(paired, standard_error, 0.0),
    )


class HeldOutReliability:
    """Per-node held-out sets, parameter snapshots and the latest verdicts (module docstring)."""

    def __init__(
        self,
        bank: ModelBank,
        size: int = 16,
        every: int = 4,
        lag: int = 20,
        z: float = 2.0,
        accurate_ratio: float = 0.5,
        initial_capacity: int = 64,
        window: int = 40,
    ) -> None:
        if size < 2 or every < 2 or lag < 1 or window < 2:
            raise ValueError(f"held-out reliability needs size >= 2, every >= 2, lag >= 1, window >= 2 (got "
                             f"{size}, {every}, {lag}, {window})")
        self.bank = bank
        self.size, self.every, self.lag = int(size), int(every), int(lag)
        self.z, self.accurate_ratio = float(z), float(accurate_ratio)
        self.min_count = max(2, self.size // 2)
        self.window = int(window)
        d, a = bank.latent_dim, bank.action_dim
        capacity = max(1, int(initial_capacity))
        self.latent = torch.zeros((capacity, self.size, d))
        self.action = torch.zeros((capacity, self.size, a))
        self.reward = torch.zeros((capacity, self.size))
        self.next_latent = torch.zeros((capacity, self.size, d))
        self.written = np.zeros(capacity, dtype=np.int64)
        self.seen = np.zeros(capacity, dtype=np.int64)
        self.updates = np.zeros(capacity, dtype=np.int64)
        self.snapshots = torch.zeros((SNAPSHOTS, capacity, bank.num_params))
        self.taken = np.zeros(capacity, dtype=np.int64)
        self.trusted = np.zeros(capacity, dtype=bool)
        self.ratio = np.full(capacity, np.nan)
        self.progress = np.zeros(capacity)
        self.standard_error = np.zeros(capacity)
        self.recent_error = np.zeros((capacity, self.window))
        self.recent_no_change = np.zeros((capacity, self.window))
        self.recent_count = np.zeros(capacity, dtype=np.int64)

    # ------------------------------------------------------------------ capacity and node events
    @property
    def capacity(self) -> int:
        return self.written.shape[0]

    def ensure_capacity(self, size: int) -> None:
        old = self.capacity
        if size <= old:
            return
        new = grown_capacity(old, size)
        pad = new - old

        def grow(t: torch.Tensor) -> torch.Tensor:
            return torch.cat([t, torch.zeros((pad, *t.shape[1:]), dtype=t.dtype)])

        self.latent, self.action = grow(self.latent), grow(self.action)
        self.reward, self.next_latent = grow(self.reward), grow(self.next_latent)
        extra = torch.zeros((SNAPSHOTS, pad, self.snapshots.shape[2]))
        self.snapshots = torch.cat([self.snapshots, extra], dim=1)
        self.taken = np.concatenate([self.taken, np.zeros(pad, np.int64)])
        self.written = np.concatenate([self.written, np.zeros(pad, np.int64)])
        self.seen = np.concatenate([self.seen, np.zeros(pad, np.int64)])
        self.updates = np.concatenate([self.updates, np.zeros(pad, np.int64)])
        self.trusted = np.concatenate([self.trusted, np.zeros(pad, bool)])
        self.ratio = np.concatenate([self.ratio, np.full(pad, np.nan)])
        self.progress = np.concatenate([self.progress, np.zeros(pad)])
        self.standard_error = np.concatenate([self.standard_error, np.zeros(pad)])
        self.recent_error = np.concatenate([self.recent_error, np.zeros((pad, self.window))])
        self.recent_no_change = np.concatenate([self.recent_no_change, np.zeros((pad, self.window))])
        self.recent_count = np.concatenate([self.recent_count, np.zeros(pad, np.int64)])

    def reset_nodes(self, node_ids: list[int] | np.ndarray) -> None:
        """Forget the held-out sets, snapshots and verdicts of these slots."""
        ids = np.asarray(node_ids, dtype=np.int64).reshape(-1)
        if ids.size == 0:
            return
        self.ensure_capacity(int(ids.max()) + 1)
        self.written[ids] = 0
        self.seen[ids] = 0
        self.updates[ids] = 0
        self.trusted[ids] = False
        self.ratio[ids] = np.nan
        self.progress[ids] = 0.0
        self.standard_error[ids] = 0.0
        self.taken[ids] = 0
        self.recent_count[ids] = 0

    # ------------------------------------------------------------------ per real transition
    def route_to_heldout(self, node: int) -> bool:
        """Count one real transition of ``node``; True when it is the node's every-k-th (held out)."""
        self.ensure_capacity(node + 1)
        self.seen[node] += 1
        return bool(self.seen[node] % self.every == 0)

    def record(self, node: int, error: float, no_change: float) -> None:
        """The Eq. 8 error of a new transition of ``node`` (before the model learnt from it) and the no-change
        predictor's: the window the verdict's ratio is taken over."""
        self.ensure_capacity(node + 1)
        slot = int(self.recent_count[node] % self.window)
        self.recent_error[node, slot] = error
        self.recent_no_change[node, slot] = no_change
        self.recent_count[node] += 1

    def add(self, node: int, phi: torch.Tensor, action: torch.Tensor, reward: float,
            next_phi: torch.Tensor) -> None:
        """Put one real transition into ``node``'s held-out ring."""
        self.ensure_capacity(node + 1)
        slot = int(self.written[node] % self.size)
        self.latent[node, slot] = phi.reshape(-1)
        self.action[node, slot] = action.reshape(-1)
        self.reward[node, slot] = float(reward)
        self.next_latent[node, slot] = next_phi.reshape(-1)
        self.written[node] += 1

    def after_update(self, nodes: np.ndarray | list[int]) -> None:
        """Count one real model update per node, rotate its snapshots every ``lag`` updates, re-judge it."""
        ids = np.unique(np.asarray(nodes, dtype=np.int64).reshape(-1))
        if ids.size == 0:
            return
        self.ensure_capacity(int(ids.max()) + 1)
        self.updates[ids] += 1
        rotate = ids[self.updates[ids] % self.lag == 0]
        if rotate.size:
            index = torch.from_numpy(rotate)
            self.snapshots[torch.from_numpy(self.taken[rotate] % SNAPSHOTS), index] = self.bank.theta[index]
            self.taken[rotate] += 1
        due = ids[self.updates[ids] % EVALUATE_EVERY == 0]
        if due.size:
            self.evaluate(due)

    @torch.no_grad()
    def evaluate(self, nodes: np.ndarray | list[int]) -> Verdict:
        """Re-judge the nodes on their held-out sets (one batched forward of current + snapshot models)."""
        ids = np.unique(np.asarray(nodes, dtype=np.int64).reshape(-1))
        self.ensure_capacity(int(ids.max()) + 1 if ids.size else 0)
        k, n = ids.size, self.size
        index = torch.from_numpy(ids)
        phi = self.latent[index].reshape(k * n, -1)
        action = self.action[index].reshape(k * n, -1)
        reward = self.reward[index].reshape(-1)
        target = self.next_latent[index].reshape(k * n, -1)
        taken = self.taken[ids]
        recent = torch.from_numpy((taken - 2) % SNAPSHOTS)  # taken one rotation before the newest
        oldest = torch.from_numpy(np.where(taken >= SNAPSHOTS, taken % SNAPSHOTS, 0))
        snapshots = self.snapshots
        rows = torch.cat([self.bank.theta[index], snapshots[recent, index], snapshots[oldest, index]])
        prediction = self.bank.predict_rows(rows.repeat_interleave(n, dim=0), phi.repeat(3, 1),
                                            action.repeat(3, 1))
        errors = self.bank.errors(prediction.next_latent, prediction.reward, target.repeat(3, 1),
                                  reward.repeat(3)).double().numpy().reshape(3, k, n)
        no_change = self.bank.errors(phi, torch.zeros_like(reward), target, reward).double().numpy()
        mask = np.arange(n)[None, :] < np.minimum(self.written[ids], n)[:, None]
        filled = np.minimum(self.recent_count[ids], self.window)
        recent_mask = np.arange(self.window)[None, :] < filled[:, None]
        recent = (self.recent_error[ids], self.recent_no_change[ids], recent_mask)
        verdict = judge(errors[0], [errors[1], errors[2]], no_change.reshape(k, n), mask, self.z,
                        self.accurate_ratio, self.min_count, comparable=taken >= 2, recent=recent)
        self.trusted[ids] = verdict.trusted
        self.ratio[ids] = verdict.ratio
        self.progress[ids] = verdict.progress
        self.standard_error[ids] = verdict.standard_error
        return verdict

    # ------------------------------------------------------------------ queries
    def is_trusted(self, nodes: np.ndarray | list[int] | int) -> np.ndarray:
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self.ensure_capacity(int(ids.max()) + 1 if ids.size else 0)
        return self.trusted[ids].copy()

    def held(self, node: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """``node``'s held-out transitions (the filled part of its ring): φ ``[n, d]``, a ``[n, a]``,
        r ``[n]``, φ′ ``[n, d]``."""
        self.ensure_capacity(node + 1)
        n = int(min(self.written[node], self.size))
        return (self.latent[node, :n], self.action[node, :n], self.reward[node, :n],
                self.next_latent[node, :n])

    def progress_of(self, nodes: np.ndarray | list[int] | int) -> np.ndarray:
        """Held-out progress per node (paired error decrease since the recent snapshot; 0 while undefined)."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self.ensure_capacity(int(ids.max()) + 1 if ids.size else 0)
        return self.progress[ids].copy()

    def relative_error(self, nodes: np.ndarray | list[int] | int) -> np.ndarray:
        """Prediction error the novelty planner aims at (``dual.planner = novelty``): the node's error ratio
        to "nothing changes", clipped to [0, 1]; 1 while undefined (an unjudged region is unknown)."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self.ensure_capacity(int(ids.max()) + 1 if ids.size else 0)
        return np.clip(np.nan_to_num(self.ratio[ids], nan=1.0), 0.0, 1.0)

    def share(self, nodes: np.ndarray | list[int] | int, max_ratio: float = 1.0) -> np.ndarray:
        """`share_from_ratio` of each node's held-out ratio (0 while undefined)."""
        ids = np.asarray(nodes, dtype=np.int64).reshape(-1)
        self.ensure_capacity(int(ids.max()) + 1 if ids.size else 0)
        return share_from_ratio(np.nan_to_num(self.ratio[ids], nan=1.0), max_ratio)

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict[str, torch.Tensor]:
        return {
            "latent": self.latent.clone(), "action": self.action.clone(), "reward": self.reward.clone(),
            "next_latent": self.next_latent.clone(), "written": torch.from_numpy(self.written.copy()),
            "seen": torch.from_numpy(self.seen.copy()), "updates": torch.from_numpy(self.updates.copy()),
            "snapshots": self.snapshots.clone(), "taken": torch.from_numpy(self.taken.copy()),
            "trusted": torch.from_numpy(self.trusted.copy()), "ratio": torch.from_numpy(self.ratio.copy()),
            "progress": torch.from_numpy(self.progress.copy()),
            "standard_error": torch.from_numpy(self.standard_error.copy()),
            "recent_error": torch.from_numpy(self.recent_error.copy()),
            "recent_no_change": torch.from_numpy(self.recent_no_change.copy()),
            "recent_count": torch.from_numpy(self.recent_count.copy()),
        }

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        if state["latent"].shape[1] != self.size:
            raise ValueError("held-out reliability checkpoint has a different held-out size")
        for name in ("latent", "action", "reward", "next_latent", "snapshots"):
            setattr(self, name, state[name].clone())
        for name in ("written", "seen", "updates", "taken", "trusted", "ratio", "progress",
                     "standard_error", "recent_error", "recent_no_change", "recent_count"):
            setattr(self, name, state[name].numpy().copy())
