"""Per-node learning progress (paper Eq. 8-9) and the intrinsic reward r_int = −LP.

For each ITM node n the tracker keeps

- a window of the σ most recent prediction errors e^prd (Eq. 8; computed by the model bank before
  the model's update) and its mean ⟨e_{t,n}⟩ — a partial window averages the errors it has;
- the history of window means, one appended per recorded error, the last W + 1 of them;

and defines LP_{t,n} = ⟨e_{t−W,n}⟩ − ⟨e_{t,n}⟩ (Eq. 9), with t counting that node's own recorded
errors. Everything is stored in stacked NumPy arrays ``[capacity, σ]`` / ``[capacity, W+1]``.

Two readings (see docs/dual-system.md):

- ``warmup="unreliable"`` (paper): until a node holds W + 1 means, ⟨e_{t−W}⟩ does not exist, the
  node counts as unreliable (model-free) and its intrinsic reward is 0.
- ``warmup="zero_oldest"`` (authors' code): LP = oldest mean in the history − current mean; while
  only one mean exists the oldest counts as 0, so a new node starts with negative LP (model-free).
- ``normalise=True`` (authors' code) divides LP by the maximum of the history (0 when that is 0).

The released code keeps the last W means (lag W − 1 once full); this tracker keeps W + 1 in both
readings, so a full history always compares means exactly W recordings apart, as Eq. 9 prints.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import torch

from core.dual.capacity import grown_capacity

LpWarmup = Literal["unreliable", "zero_oldest"]


class LearningProgress:
    """Windowed prediction errors and learning progress for every ITM node (Eq. 8-9)."""

    def __init__(
        self,
        window: int = 40,
        history: int = 20,
        normalise: bool = False,
        warmup: LpWarmup = "unreliable",
        scale: float = 1.0,
        initial_capacity: int = 64,
    ) -> None:
        if window < 1:
            raise ValueError(f"learning-progress window σ must be >= 1, got {window}")
        if history < 1:
            raise ValueError(f"learning-progress history W must be >= 1, got {history}")
        if warmup not in ("unreliable", "zero_oldest"):
            raise ValueError(f"warmup must be 'unreliable' or 'zero_oldest', got {warmup!r}")
        self.window = window
        self.history = history
        self.normalise = normalise
        self.warmup: LpWarmup = warmup
        self.scale = float(scale)
        capacity = max(1, int(initial_capacity))
        self._errors = np.zeros((capacity, window))
        self._n_errors = np.zeros(capacity, dtype=np.int64)
        self._means = np.zeros((capacity, history + 1))
        self._n_means = np.zeros(capacity, dtype=np.int64)

    @property
    def capacity(self) -> int:
        return self._n_errors.shape[0]

    def ensure_capacity(self, size: int) -> None:
        """Grow the per-node arrays geometrically (×2) until ``size`` slots exist."""
        old = self.capacity
        if size <= old:
            return
        new = grown_capacity(old, size)
        self._errors = np.concatenate([self._errors, np.zeros((new - old, self.window))])
        self._n_errors = np.concatenate([self._n_errors, np.zeros(new - old, dtype=np.int64)])
        self._means = np.concatenate([self._means, np.zeros((new - old, self.history + 1))])
        self._n_means = np.concatenate([self._n_means, np.zeros(new - old, dtype=np.int64)])

    def reset_nodes(self, node_ids: np.ndarray | list[int] | tuple[int, ...]) -> None:
        """Forget everything about these slots (new or reused ITM nodes)."""
        ids = np.asarray(node_ids, dtype=np.int64).reshape(-1)
        if ids.size == 0:
            return
        self.ensure_capacity(int(ids.max()) + 1)
        self._errors[ids] = 0.0
        self._n_errors[ids] = 0
        self._means[ids] = 0.0
        self._n_means[ids] = 0

    # ------------------------------------------------------------------ recording
    def record(
        self, node_ids: np.ndarray | list[int] | int, errors: np.ndarray | torch.Tensor | float
    ) -> None:
        """Append each error to its node's window, then append the new window mean to the history.

        Repeated ids are applied in order of appearance (a loop over multiplicity, vectorised over
        nodes).
        """
        ids = np.asarray(node_ids, dtype=np.int64).reshape(-1)
        e = errors.detach().cpu().numpy() if isinstance(errors, torch.Tensor) else np.asarray(errors)
        e = e.astype(np.float64).reshape(-1)
        if ids.size != e.size:
            raise ValueError(f"record got {ids.size} node ids for {e.size} errors")
        if ids.size == 0:
            return
        if not np.all(np.isfinite(e)):
            raise ValueError("learning progress got a non-finite prediction error")
        self.ensure_capacity(int(ids.max()) + 1)
        order = np.argsort(ids, kind="stable")
        sorted_ids = ids[order]
        first = np.searchsorted(sorted_ids, sorted_ids, side="left")
        rank = np.empty_like(ids)
        rank[order] = np.arange(ids.size) - first
        for r in range(int(rank.max()) + 1):
            sel = rank == r
            self._record_unique(ids[sel], e[sel])

    def _record_unique(self, ids: np.ndarray, e: np.ndarray) -> None:
        self._errors[ids, self._n_errors[ids] % self.window] = e
        self._n_errors[ids] += 1
        filled = np.minimum(self._n_errors[ids], self.window)
        mean = self._errors[ids].sum(axis=1) / filled
        self._means[ids, self._n_means[ids] % (self.history + 1)] = mean
        self._n_means[ids] += 1

    # ------------------------------------------------------------------ queries
    def window_mean(self, node_ids: np.ndarray | list[int] | int) -> np.ndarray:
        """⟨e_{t,n}⟩, the mean of each node's current error window (0 when it holds none)."""
        ids = np.asarray(node_ids, dtype=np.int64).reshape(-1)
        n = self._n_means[ids]
        current = self._means[ids, (n - 1) % (self.history + 1)]
        return np.where(n > 0, current, 0.0)

    def error_count(self, node_ids: np.ndarray | list[int] | int) -> np.ndarray:
        """How many errors each node has recorded since it was (re)created."""
        ids = np.asarray(node_ids, dtype=np.int64).reshape(-1)
        self.ensure_capacity(int(ids.max()) + 1 if ids.size else 0)
        return self._n_errors[ids].copy()

    def learning_progress(self, node_ids: np.ndarray | list[int] | int) -> np.ndarray:
        """LP_{t,n} (Eq. 9) per node; NaN where the node is unreliable for lack of history."""
        ids = np.asarray(node_ids, dtype=np.int64).reshape(-1)
        self.ensure_capacity(int(ids.max()) + 1 if ids.size else 0)
        size = self.history + 1
        n = self._n_means[ids]
        current = self._means[ids, (n - 1) % size]
        full = n >= size
        oldest = np.where(full, self._means[ids, n % size], self._means[ids, 0])
        if self.warmup == "zero_oldest":
            oldest = np.where(n == 1, 0.0, oldest)
            defined = n >= 1
        else:
            defined = full
        lp = oldest - current
        if self.normalise:
            stored = np.minimum(n, size)
            mask = np.arange(size)[None, :] < stored[:, None]
            peak = np.where(mask, self._means[ids], 0.0).max(axis=1)
            lp = np.divide(lp, peak, out=np.zeros_like(lp), where=peak > 0)
        return np.where(defined, lp, np.nan)

    def reliable(self, node_ids: np.ndarray | list[int] | int) -> np.ndarray:
        """Meta-controller test (Section 2.3.2): LP defined and ≥ 0 → model-based."""
        lp = self.learning_progress(node_ids)
        return np.nan_to_num(lp, nan=-np.inf) >= 0.0

    def intrinsic_reward(self, node_ids: np.ndarray | list[int] | int) -> np.ndarray:
        """r_int = −scale·LP (Alg. 2 line 22); 0 where LP is undefined."""
        return -self.scale * np.nan_to_num(self.learning_progress(node_ids), nan=0.0)

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict[str, torch.Tensor]:
        return {
            "errors": torch.from_numpy(self._errors.copy()),
            "n_errors": torch.from_numpy(self._n_errors.copy()),
            "means": torch.from_numpy(self._means.copy()),
            "n_means": torch.from_numpy(self._n_means.copy()),
        }

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        if state["errors"].shape[1] != self.window or state["means"].shape[1] != self.history + 1:
            raise ValueError("learning-progress checkpoint has a different window or history length")
        self._errors = state["errors"].numpy().copy()
        self._n_errors = state["n_errors"].numpy().copy()
        self._means = state["means"].numpy().copy()
        self._n_means = state["n_means"].numpy().copy()
