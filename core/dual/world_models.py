"""The self-organised latent world model: ITM regions, their local models and learning progress, kept in step.

`LocalWorldModels` owns one `InstantaneousTopologicalMap`, one `ModelBank` and one `LearningProgress`
and keeps their per-node state consistent: every node the ITM adds gets a fresh (or parent-copied) model
and an empty error window; a freed slot is reset before reuse. Per real step it does Alg. 2 lines
10-11 (`observe_state`: update the map with φ_t, return the best-matching node n) and lines 22 + 25
(`learn_transition`: the Eq. 8 error of M_n, R_n on (φ_t, a_t, r^ext_t, φ_{t+1}) computed before the
model's Eq. 5 update, recorded into n's window; returns the error and r_int = −scale·LP_{t,n}).

``regions=False`` gives the single global model of the baselines (DDPG+CMC, MVE-DDPG): no map, node 0
always, temporal-only learning progress.

``model_batch > 1`` (a documented option, ``dual.model_batch``): each node also keeps its last
``model_batch − 1`` real transitions and the Eq. 5 step uses them together with the new one (the mean
loss over that small per-node minibatch); the LP error is always the new transition's alone. With the
default 1 the step uses the one real transition, as Alg. 2 line 25 and the released code do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from core.config import DualConfig
from core.dual.capacity import grown_capacity
from core.dual.itm import InstantaneousTopologicalMap
from core.dual.itm_resolution import RelativeResolution
from core.dual.learning_progress import LearningProgress
from core.dual.model_bank import ModelBank


@dataclass(frozen=True)
class TransitionFeedback:
    """What learning from one real transition produced (Alg. 2 lines 22-25)."""

    error: float
    """e^prd of the node's model on the transition, before its update (Eq. 8)."""
    intrinsic_reward: float
    """r_int = −scale·LP_{t,n} after recording the error."""


class LocalWorldModels:
    """ITM + per-node world models + per-node learning progress (Sections 2.2-2.3)."""

    def __init__(
        self,
        dual: DualConfig,
        latent_dim: int,
        action_dim: int,
        regions: bool = True,
        generator: torch.Generator | None = None,
    ) -> None:
        self.config = dual
        self.latent_dim = latent_dim
        self.action_dim = action_dim
        self.regions = regions
        capacity = 64 if regions else 1
        self.itm = (
            InstantaneousTopologicalMap(latent_dim, dual.e_max, dual.itm_distance, initial_capacity=capacity)
            if regions else None
        )
        self.resolution = (
            RelativeResolution(dual.e_max_relative, latent_dim)
            if regions and dual.e_max_relative is not None
            else None
        )
        self.bank = ModelBank(
            latent_dim=latent_dim,
            action_dim=action_dim,
            hidden=dual.model_hidden,
            lr=dual.model_lr,
            output_activation=dual.model_output,
            init=dual.new_node_model,
            error_norm=dual.error_norm,
            initial_capacity=capacity,
            generator=generator,
        )
        self.lp = LearningProgress(
            window=dual.lp_sigma,
            history=dual.lp_window,
            normalise=dual.lp_normalise,
            warmup=dual.lp_warmup,
            scale=dual.intrinsic_scale,
            initial_capacity=capacity,
        )
        self.memory_size = max(0, dual.model_batch - 1)
        self._memory = (
            _NodeMemory(self.memory_size, latent_dim, action_dim, capacity) if self.memory_size else None
        )

    # ------------------------------------------------------------------ Alg. 2 lines 10-11
    def observe_state(self, phi: torch.Tensor) -> int:
        """Update the map with φ_t and return the best-matching node (0 for the global model)."""
        if self.itm is None:
            return 0
        if self.resolution is not None:
            self._set_resolution(self.resolution.observe(phi))
        events = self.itm.update(phi)
        if events.removed:
            self._reset(list(events.removed))
        if events.added:
            self.bank.reset_nodes(list(events.added), parents=list(events.parents))
            self.lp.reset_nodes(list(events.added))
            if self._memory is not None:
                self._memory.reset(list(events.added))
        return events.winner

    def _set_resolution(self, distance: float | None) -> None:
        """Set the ITM's e_max to the L2 threshold `distance` (squared if the map compares squared ones)."""
        if distance is not None and self.itm is not None:
            self.itm.e_max = distance if self.itm.distance == "l2" else distance * distance

    def _reset(self, nodes: list[int]) -> None:
        self.lp.reset_nodes(nodes)
        if self._memory is not None:
            self._memory.reset(nodes)

    def nearest(self, phi: torch.Tensor) -> int:
        """Best-matching node of a (predicted) latent without adapting the map (Alg. 1 line 5)."""
        if self.itm is None:
            return 0
        return int(self.itm.nearest(phi)[0])

    @property
    def num_nodes(self) -> int:
        return 1 if self.itm is None else self.itm.num_nodes

    # ------------------------------------------------------------------ Alg. 2 lines 22 and 25
    def learn_transition(
        self, node: int, phi: torch.Tensor, action: torch.Tensor, reward_ext: float, next_phi: torch.Tensor
    ) -> TransitionFeedback:
        """Eq. 8 error (before the update) → LP window of ``node``; one Eq. 5 step of ``node``'s model."""
        phi = phi.reshape(1, -1)
        action = torch.as_tensor(action, dtype=torch.float32).reshape(1, -1)
        next_phi = next_phi.reshape(1, -1)
        reward = torch.tensor([float(reward_ext)])
        if self._memory is not None and self._memory.count(node) > 0:
            old = self._memory.get(node)
            count = old[0].shape[0]
            errors = self.bank.update(
                torch.full((count + 1,), node, dtype=torch.int64),
                torch.cat([phi, old[0]]), torch.cat([action, old[1]]),
                torch.cat([next_phi, old[3]]), torch.cat([reward, old[2]]),
            )
        else:
            errors = self.bank.update(torch.tensor([node]), phi, action, next_phi, reward)
        if self._memory is not None:
            self._memory.add(node, phi[0], action[0], float(reward_ext), next_phi[0])
        error = float(errors[0])
        self.lp.record([node], [error])
        return TransitionFeedback(error=error, intrinsic_reward=float(self.lp.intrinsic_reward(node)[0]))

    def learn_batch(
        self, phi: torch.Tensor, action: torch.Tensor, reward_ext: torch.Tensor, next_phi: torch.Tensor
    ) -> torch.Tensor:
        """One Eq. 5 step of the global model (node 0) on a minibatch; returns the pre-update errors (MVE)."""
        nodes = torch.zeros(phi.shape[0], dtype=torch.int64)
        errors = self.bank.update(nodes, phi, action, next_phi, reward_ext)
        return errors

    def refit(
        self, phi: torch.Tensor, action: torch.Tensor, reward_ext: torch.Tensor, next_phi: torch.Tensor
    ) -> torch.Tensor:
        """One Eq. 5 step of each node a batch of re-encoded real transitions touches (``dual.refit_every``).

        Each sample goes to its nearest node (the map is not adapted, as in Alg. 1 line 5); each touched
        node takes one Adam step on the mean loss of its samples. The learning-progress windows are left
        alone: they hold the errors of the real transitions as they arrived. Returns the pre-update Eq. 8
        errors ``[B]``, i.e. how far the models had drifted from the current encoder's latents.
        """
        if self.itm is None:
            nodes = torch.zeros(phi.shape[0], dtype=torch.int64)
        else:
            nodes = torch.from_numpy(self.itm.nearest(phi))
        return self.bank.update(nodes, phi, action, next_phi, reward_ext)

    # ------------------------------------------------------------------ queries
    def reliable(self, node: int) -> bool:
        """LP_{t,n} ≥ 0 (Section 2.3.2): the meta-controller may use the model-based system."""
        return bool(self.lp.reliable(node)[0])

    def learning_progress(self, node: int) -> float:
        return float(self.lp.learning_progress(node)[0])

    def mean_error(self, node: int) -> float:
        """⟨e_{t,n}⟩ of the node's current window (NaN when it holds no error yet)."""
        if self.lp.error_count(node)[0] == 0:
            return float("nan")
        return float(self.lp.window_mean(node)[0])

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict[str, dict[str, torch.Tensor]]:
        state: dict[str, dict[str, torch.Tensor]] = {
            "bank": self.bank.state_dict(),
            "lp": self.lp.state_dict(),
        }
        if self.itm is not None:
            state["itm"] = self.itm.state_dict()
        if self._memory is not None:
            state["memory"] = self._memory.state_dict()
        if self.resolution is not None:
            state["resolution"] = self.resolution.state_dict()
        state["generator"] = {"state": self.bank.generator.get_state()}
        return state

    def load_state_dict(self, state: dict[str, dict[str, torch.Tensor]]) -> None:
        self.bank.load_state_dict(state["bank"])
        self.lp.load_state_dict(state["lp"])
        if self.itm is not None:
            self.itm.load_state_dict(state["itm"])
        if self._memory is not None:
            self._memory.load_state_dict(state["memory"])
        if self.resolution is not None:
            self.resolution.load_state_dict(state["resolution"])
            self._set_resolution(self.resolution.current)
        self.bank.generator.set_state(state["generator"]["state"])


class _NodeMemory:
    """Each node's last ``size`` real transitions, stacked ``[capacity, size, ...]`` (for ``model_batch``)."""

    def __init__(self, size: int, latent_dim: int, action_dim: int, capacity: int) -> None:
        self.size = size
        self.latent = np.zeros((capacity, size, latent_dim), dtype=np.float32)
        self.action = np.zeros((capacity, size, action_dim), dtype=np.float32)
        self.reward = np.zeros((capacity, size), dtype=np.float32)
        self.next_latent = np.zeros((capacity, size, latent_dim), dtype=np.float32)
        self.written = np.zeros(capacity, dtype=np.int64)

    def _grow(self, node: int) -> None:
        capacity = self.written.shape[0]
        if node < capacity:
            return
        new = grown_capacity(capacity, node + 1)
        pad = new - capacity
        self.latent = np.concatenate([self.latent, np.zeros((pad, *self.latent.shape[1:]), np.float32)])
        self.action = np.concatenate([self.action, np.zeros((pad, *self.action.shape[1:]), np.float32)])
        self.reward = np.concatenate([self.reward, np.zeros((pad, self.size), np.float32)])
        self.next_latent = np.concatenate(
            [self.next_latent, np.zeros((pad, *self.next_latent.shape[1:]), np.float32)]
        )
        self.written = np.concatenate([self.written, np.zeros(pad, np.int64)])

    def count(self, node: int) -> int:
        self._grow(node)
        return int(min(self.written[node], self.size))

    def get(self, node: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        n = self.count(node)
        return (torch.from_numpy(self.latent[node, :n]), torch.from_numpy(self.action[node, :n]),
                torch.from_numpy(self.reward[node, :n]), torch.from_numpy(self.next_latent[node, :n]))

    def add(self, node: int, latent: torch.Tensor, action: torch.Tensor, reward: float,
            next_latent: torch.Tensor) -> None:
        self._grow(node)
        slot = int(self.written[node] % self.size)
        self.latent[node, slot] = latent.numpy()
        self.action[node, slot] = action.numpy()
        self.reward[node, slot] = reward
        self.next_latent[node, slot] = next_latent.numpy()
        self.written[node] += 1

    def reset(self, nodes: list[int]) -> None:
        for node in nodes:
            self._grow(node)
        self.written[nodes] = 0

    def state_dict(self) -> dict[str, torch.Tensor]:
        return {"latent": torch.from_numpy(self.latent.copy()),
                "action": torch.from_numpy(self.action.copy()),
                "reward": torch.from_numpy(self.reward.copy()),
                "next_latent": torch.from_numpy(self.next_latent.copy()),
                "written": torch.from_numpy(self.written.copy())}

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self.latent = state["latent"].numpy().copy()
        self.action = state["action"].numpy().copy()
        self.reward = state["reward"].numpy().copy()
        self.next_latent = state["next_latent"].numpy().copy()
        self.written = state["written"].numpy().copy()
