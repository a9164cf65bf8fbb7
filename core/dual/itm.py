"""Instantaneous Topological Map (ITM) over the latent space (paper Section 2.3.1).

The ITM partitions the latent space into regions; each node owns a local world model
(`core.dual.model_bank.ModelBank`) and a learning-progress tracker (`core.dual.learning_progress`).
Per stimulus φ the map runs the three adaptation steps of Section 2.3.1:

1. Matching: n = argmin_i ‖φ − w_i‖², n′ = argmin_{j≠n} ‖φ − w_j‖².
2. Edge adaptation: connect n–n′; for every neighbour m of n, remove the edge m–n when n′ lies
   inside the Thales sphere through m and n, i.e. (w_n − w_n′)·(w_m − w_n′) < 0; remove m when it
   has no edge left.
3. Node adaptation: when φ lies outside the Thales sphere through n and n′, i.e.
   (w_n − φ)·(w_n′ − φ) > 0, and its distance to w_n exceeds e_max, add a node at φ with an edge to n.

Decisions written down here (the paper is silent or differs from the released code):

- Distance compared with e_max: ``distance="l2"`` compares the unsquared norm ‖φ − w_n‖ with
  e_max (the authors' released code, e_max = 6); ``distance="squared"`` compares ‖φ − w_n‖² (the
  paper's text).
- Start: "the network starts with two connected nodes". Without explicit ``initial_weights`` both
  nodes are placed at the first stimulus (released code). Ties in matching go to the lower id, so
  the second of two coincident nodes never wins a match; it is harmless (it only ever serves as
  n′) and is kept for fidelity.
- Node ids are slot indices into preallocated arrays and stay stable while the node lives. A
  removed node frees its slot and the lowest free slot is reused by the next added node: owners of
  per-node state must reset a slot whenever it appears in ``ItmEvents.added`` (they do, see
  `ModelBank.reset_nodes` and `LearningProgress.reset_nodes`).
- The winner reported after an update is the best-matching node *after* adaptation: the new node
  when one was created at φ (distance 0), else n. Node n itself can never be removed by its own
  update (it stays connected to n′).

- Pruning (``dual.region_prune_after``, not in the paper): `prune_idle` removes the nodes that have not been
  the winner for a given number of updates, so regions left behind by a drifting latent (or by an early,
  poorly normalised stretch of it) do not accumulate. At least the two most recent winners always stay.

All work is vectorised over nodes with NumPy (weights ``[capacity, dim]`` float64, adjacency a
boolean ``[capacity, capacity]`` matrix); capacity grows geometrically.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch

from core.dual.capacity import grown_capacity

ItmDistance = Literal["l2", "squared"]


@dataclass(frozen=True)
class ItmEvents:
    """What one `InstantaneousTopologicalMap.update` did, for the owners of per-node state."""

    winner: int
    """Best-matching node for the stimulus after adaptation (the new node if one was added)."""
    matched: int
    """n: the nearest node before adaptation."""
    second: int
    """n′: the second-nearest node before adaptation."""
    added: tuple[int, ...]
    """Slots of nodes created by this update (at most one)."""
    removed: tuple[int, ...]
    """Slots of nodes deleted by this update (they lost their last edge)."""
    parents: tuple[int, ...]
    """For each added node, the node it was connected to (n)."""


class InstantaneousTopologicalMap:
    """Growing topological map with stable node ids (Section 2.3.1, Jockusch & Ritter's ITM)."""

    def __init__(
        self,
        dim: int,
        e_max: float,
        distance: ItmDistance = "l2",
        initial_capacity: int = 64,
        initial_weights: np.ndarray | None = None,
    ) -> None:
        if dim < 1:
            raise ValueError(f"ITM dim must be >= 1, got {dim}")
        if e_max <= 0:
            raise ValueError(f"ITM e_max must be > 0, got {e_max}")
        if distance not in ("l2", "squared"):
            raise ValueError(f"ITM distance must be 'l2' or 'squared', got {distance!r}")
        self.dim = dim
        self.e_max = float(e_max)
        self.distance: ItmDistance = distance
        capacity = max(2, int(initial_capacity))
        self._weights = np.zeros((capacity, dim), dtype=np.float64)
        self._alive = np.zeros(capacity, dtype=bool)
        self._adjacency = np.zeros((capacity, capacity), dtype=bool)
        self._last_win = np.zeros(capacity, dtype=np.int64)
        self.updates = 0
        """Stimuli seen (`update` calls); the clock of `prune_idle`."""
        if initial_weights is not None:
            w = np.asarray(initial_weights, dtype=np.float64)
            if w.shape != (2, dim):
                raise ValueError(f"initial_weights must have shape (2, {dim}), got {w.shape}")
            self._place_initial_pair(w)

    # ------------------------------------------------------------------ introspection
    @property
    def capacity(self) -> int:
        """Number of preallocated slots (grows geometrically)."""
        return self._alive.shape[0]

    @property
    def num_nodes(self) -> int:
        """Number of live nodes."""
        return int(self._alive.sum())

    @property
    def initialised(self) -> bool:
        """Whether the two initial nodes exist (placed at construction or at the first stimulus)."""
        return bool(self._alive.any())

    def alive_ids(self) -> np.ndarray:
        """Ids of the live nodes, ascending."""
        return np.flatnonzero(self._alive)

    def weights(self, node_ids: np.ndarray | int | None = None) -> np.ndarray:
        """Weight vectors of the given nodes (all live nodes when None), a copy."""
        ids = self.alive_ids() if node_ids is None else np.asarray(node_ids)
        return self._weights[ids].copy()

    def is_alive(self, node: int) -> bool:
        return 0 <= node < self.capacity and bool(self._alive[node])

    def neighbours(self, node: int) -> np.ndarray:
        """Ids of the nodes connected to ``node``."""
        return np.flatnonzero(self._adjacency[node])

    def adjacency(self, node_ids: np.ndarray) -> np.ndarray:
        """The edges among ``node_ids`` as a boolean matrix ``[len, len]`` (row i, column j: ids i and j are
        connected), a copy."""
        ids = np.asarray(node_ids)
        return self._adjacency[np.ix_(ids, ids)].copy()

    def edges(self) -> set[tuple[int, int]]:
        """All edges as ``(low id, high id)`` pairs."""
        rows, cols = np.nonzero(np.triu(self._adjacency, k=1))
        return {(int(r), int(c)) for r, c in zip(rows, cols, strict=True)}

    # ------------------------------------------------------------------ matching
    def nearest(self, phi: np.ndarray | torch.Tensor) -> np.ndarray:
        """Best-matching node for each row of ``phi`` ``[B, dim]`` (or one ``[dim]`` vector).

        One batched distance computation over all live nodes; returns int64 ids ``[B]`` (or ``[1]``).
        """
        if not self.initialised:
            raise RuntimeError("ITM has no nodes yet: call update() with a first stimulus")
        x = phi.detach().cpu().numpy() if isinstance(phi, torch.Tensor) else np.asarray(phi)
        x = np.atleast_2d(x).astype(np.float64, copy=False)
        ids = self.alive_ids()
        w = self._weights[ids]
        # ‖x − w‖² = ‖x‖² − 2 x·w + ‖w‖²; the ‖x‖² term does not change the argmin.
        scores = (w * w).sum(axis=1)[None, :] - 2.0 * x @ w.T
        return ids[np.argmin(scores, axis=1)]

    def _two_nearest(self, phi: np.ndarray) -> tuple[int, int]:
        ids = self.alive_ids()
        d2 = ((self._weights[ids] - phi) ** 2).sum(axis=1)
        order = np.argsort(d2, kind="stable")
        return int(ids[order[0]]), int(ids[order[1]])

    # ------------------------------------------------------------------ adaptation
    def update(self, phi: np.ndarray | torch.Tensor, grow: bool = True) -> ItmEvents:
        """Adapt the map to one stimulus φ (the three steps of Section 2.3.1); ``grow=False`` skips step 3."""
        x = phi.detach().cpu().numpy() if isinstance(phi, torch.Tensor) else np.asarray(phi)
        x = x.astype(np.float64, copy=False).reshape(-1)
        if x.shape[0] != self.dim:
            raise ValueError(f"ITM stimulus must have {self.dim} components, got {x.shape[0]}")
        self.updates += 1
        if not self.initialised:
            # Released code: both initial nodes start at the first latent.
            self._place_initial_pair(np.stack([x, x]))
            return ItmEvents(winner=0, matched=0, second=1, added=(0, 1), removed=(), parents=(-1, -1))

        # 1. Matching.
        n, n2 = self._two_nearest(x)
        w = self._weights
        # 2. Edge adaptation.
        self._connect(n, n2)
        neighbours = np.flatnonzero(self._adjacency[n])
        inside = ((w[n] - w[n2]) @ (w[neighbours] - w[n2]).T) < 0.0
        dropped = neighbours[inside]
        removed: tuple[int, ...] = ()
        if dropped.size:
            self._adjacency[n, dropped] = False
            self._adjacency[dropped, n] = False
            orphans = dropped[~self._adjacency[dropped].any(axis=1)]
            if orphans.size:
                self._alive[orphans] = False
                removed = tuple(int(m) for m in orphans)
        # 3. Node adaptation.
        outside_thales = float((w[n] - x) @ (w[n2] - x)) > 0.0
        sq = float(((x - w[n]) ** 2).sum())
        dist = sq if self.distance == "squared" else float(np.sqrt(sq))
        if grow and outside_thales and dist > self.e_max:
            v = self._allocate()
            self._weights[v] = x
            self._alive[v] = True
            self._connect(v, n)
            self._last_win[v] = self.updates
            return ItmEvents(winner=v, matched=n, second=n2, added=(v,), removed=removed, parents=(n,))
        self._last_win[n] = self.updates
        return ItmEvents(winner=n, matched=n, second=n2, added=(), removed=removed, parents=())

    def prune_idle(self, max_idle: int) -> tuple[int, ...]:
        """Remove the nodes that have not won for more than ``max_idle`` updates (keeping at least two).

        Returns the removed ids; their edges go with them (a neighbour left without edges stays alive and
        reconnects when it is next matched). Owners of per-node state reset these slots like
        ``ItmEvents.removed``.
        """
        ids = self.alive_ids()
        idle = ids[self.updates - self._last_win[ids] > max_idle]
        if idle.size == 0:
            return ()
        keep = max(0, 2 - (ids.size - idle.size))
        if keep:  # spare the most recent winners among the idle ones
            order = np.argsort(-self._last_win[idle], kind="stable")
            idle = np.sort(idle[order[keep:]])
        if idle.size == 0:
            return ()
        self._alive[idle] = False
        self._adjacency[idle, :] = False
        self._adjacency[:, idle] = False
        return tuple(int(m) for m in idle)

    # ------------------------------------------------------------------ storage
    def _place_initial_pair(self, w: np.ndarray) -> None:
        self._weights[:2] = w
        self._alive[:2] = True
        self._last_win[:2] = self.updates
        self._connect(0, 1)

    def _connect(self, a: int, b: int) -> None:
        self._adjacency[a, b] = True
        self._adjacency[b, a] = True

    def _allocate(self) -> int:
        """Lowest free slot, growing the arrays geometrically (×2) when none is free."""
        free = np.flatnonzero(~self._alive)
        if free.size:
            slot = int(free[0])
            self._adjacency[slot, :] = False
            self._adjacency[:, slot] = False
            return slot
        old = self.capacity
        new = grown_capacity(old, old + 1)
        self._weights = np.concatenate([self._weights, np.zeros((new - old, self.dim))])
        self._alive = np.concatenate([self._alive, np.zeros(new - old, dtype=bool)])
        self._last_win = np.concatenate([self._last_win, np.zeros(new - old, dtype=np.int64)])
        adjacency = np.zeros((new, new), dtype=bool)
        adjacency[:old, :old] = self._adjacency
        self._adjacency = adjacency
        return old

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict[str, torch.Tensor]:
        """Tensors only, so a checkpoint loads with ``torch.load(weights_only=True)``."""
        return {
            "weights": torch.from_numpy(self._weights.copy()),
            "alive": torch.from_numpy(self._alive.copy()),
            "adjacency": torch.from_numpy(self._adjacency.copy()),
            "e_max": torch.tensor(self.e_max, dtype=torch.float64),
            "last_win": torch.from_numpy(self._last_win.copy()),
            "updates": torch.tensor(self.updates),
        }

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        weights = state["weights"].numpy().astype(np.float64)
        if weights.shape[1] != self.dim:
            raise ValueError(f"ITM checkpoint has dim {weights.shape[1]}, this map has {self.dim}")
        self._weights = weights.copy()
        self._alive = state["alive"].numpy().astype(bool).copy()
        self._adjacency = state["adjacency"].numpy().astype(bool).copy()
        self.e_max = float(state["e_max"])
        if "last_win" in state:  # checkpoints written before pruning existed lack the clock
            self._last_win = state["last_win"].numpy().astype(np.int64).copy()
            self.updates = int(state["updates"])
        else:
            self._last_win = np.zeros(self._alive.shape[0], dtype=np.int64)
            self.updates = 0
