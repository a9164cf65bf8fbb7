"""The self-organised latent world model: ITM regions, their local models and learning progress, kept in step.

`LocalWorldModels` owns one `InstantaneousTopologicalMap`, one `ModelBank`, one `LearningProgress` (Eq.
8-9) and, when a repair needs it, one `HeldOutReliability`, and keeps their per-node state consistent: every
node the ITM adds gets a fresh (or parent-copied) model, an empty error window and an empty held-out set; a
freed or pruned slot is reset before reuse. Per real step it does Alg. 2 lines 10-11 (`observe_state`:
update the map with φ_t, return the best-matching node n) and lines 22 + 25 (`learn_transition`: the Eq. 8
error of M_n, R_n on (φ_t, a_t, r^ext_t, φ_{t+1}) computed before the model's Eq. 5 update, recorded into
n's window; returns the error and r_int).

``regions=False`` gives the single global model of the baselines (DDPG+CMC, MVE-DDPG): no map, node 0
always, temporal-only learning progress.

Options (docs/dual-system.md, "Mechanisms"; each off in the ``paper`` profile):

- ``model_batch > 1``: each Eq. 5 step uses the new transition and ``model_batch − 1`` older real transitions
  of the node (the mean loss over that small per-node minibatch): its newest ones, or, with
  ``model_memory = M``, a uniform sample of its M newest (a model fitted to a sliding window of its last
  few transitions forgets the rest of its region and is judged better on anything recent); the LP error is
  always the new transition's alone.
- ``regions = repaired``: the map lives in φ / s, s the latent's running RMS spread
  (`core.dual.itm_resolution.LatentScale`), so e_max is in units of s: when the encoder's latents grow 100×
  over training, the regions do not move.
- ``world_models = repaired``: the local models read φ / s and predict changes in units of s
  (``ModelBank.latent_scale``; s over a longer horizon than the map's): their initial outputs and Adam's step
  size are relative to the latent's spread, not to its units; they predict the change φ̂′ − φ, and a new
  node's model starts as a copy of its parent's. ``region_prune_after = N`` removes nodes that have not won
  for N states.
- ``reliability = repaired``: every ``HeldOut.every``-th transition of a node is held out (not trained on) and
  the node's reliability is judged on it (`core.dual.reliability`); arbitration and Alg. 1's depth use it.
- ``intrinsic``: r_int = −c·LP (Eq. 9, the region the transition started in, Alg. 2 line 22), the same with
  the mean over the live regions removed (``paper_centred``: its dependence on the region alone, a control),
  or +c·held-out progress of the region the action led into (`intrinsic_reward`).

Each is read from the readings record handed in (``self.readings``, `core.dual.readings.resolve`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from core.config import DualConfig
from core.dual.action_map import ActionMap, fit_action_map
from core.dual.capacity import grown_capacity
from core.dual.disagreement import EnsembleDisagreement
from core.dual.goal_babbling import GoalBabbling
from core.dual.itm import InstantaneousTopologicalMap, ItmEvents
from core.dual.itm_resolution import LatentScale, RelativeResolution
from core.dual.lagged_progress import LaggedProgress
from core.dual.learning_progress import LearningProgress
from core.dual.model_bank import ModelBank
from core.dual.readings import Readings
from core.dual.region_goal import RegionGoal
from core.dual.reliability import HeldOutReliability

REGION_SCALE_HORIZON = 200
"""States over which the map's scale averages: short, to follow an encoder whose latents grow 100× in ~2000
steps (it shrinks only over 20 000, `LatentScale`)."""

MODEL_SCALE_HORIZON = 1000
"""States over which the models' units (and r_int's) average: long, since what a model has learnt moves with
them."""

PRUNE_EVERY = 64
"""States between two sweeps of `InstantaneousTopologicalMap.prune_idle` (``dual.region_prune_after``)."""


@dataclass(frozen=True)
class TransitionFeedback:
    """What learning from one real transition produced (Alg. 2 lines 22-25)."""

    error: float
    """e^prd of the node's model on the transition, before its update (Eq. 8)."""
    intrinsic_reward: float
    """r_int after recording the error (``dual.intrinsic``)."""


class LocalWorldModels:
    """ITM + per-node world models + per-node learning progress (Sections 2.2-2.3)."""

    def __init__(
        self,
        dual: DualConfig,
        latent_dim: int,
        action_dim: int,
        regions: bool = True,
        generator: torch.Generator | None = None,
        *,
        readings: Readings,
    ) -> None:
        self.config = dual
        self.readings = readings
        """The mechanisms' readings (`core.dual.readings.resolve`), resolved once by whoever builds the dual
        system and handed to the planner too (`core.dual.meta_controller.MetaController`)."""
        read = self.readings
        self.latent_dim = latent_dim
        self.action_dim = action_dim
        self.regions = regions
        capacity = 64 if regions else 1
        self.itm = (
            InstantaneousTopologicalMap(latent_dim, dual.e_max, read.regions.distance,
                                        initial_capacity=capacity)
            if regions else None
        )
        self.resolution = (
            RelativeResolution(dual.e_max_relative, latent_dim)
            if regions and dual.e_max_relative is not None
            else None
        )
        # e_max_relative is a scale-free e_max of the raw latent, refused with a normalised map (check_config)
        self.scale = (LatentScale(latent_dim, horizon=REGION_SCALE_HORIZON)
                      if regions and read.regions.normalised else None)
        self.bank = ModelBank(
            latent_dim=latent_dim,
            action_dim=action_dim,
            hidden=dual.model_hidden,
            lr=dual.model_lr,
            output_activation=read.world_models.output,
            init=read.world_models.new_node,
            error_norm=read.reliability.error_norm,
            initial_capacity=capacity,
            generator=generator,
            target=read.world_models.target,
            termination=read.imagination.termination,
        )
        self.lp = LearningProgress(
            window=dual.lp_sigma,
            history=dual.lp_window,
            normalise=read.reliability.lp_normalise,
            warmup=read.reliability.lp_warmup,
            scale=dual.intrinsic_scale,
            initial_capacity=capacity,
        )
        self.heldout = (
            HeldOutReliability(self.bank, size=read.held_out.size, every=read.held_out.every,
                               lag=read.held_out.lag, z=read.held_out.z,
                               accurate_ratio=read.held_out.accurate_ratio,
                               initial_capacity=capacity, window=dual.lp_sigma)
            if read.needs_heldout else None
        )
        if self.heldout is not None:
            self.heldout.reset_nodes(np.arange(capacity))
        self.lagged_progress = (LaggedProgress(self.bank, self.heldout) if read.planner.aim == "progress"
                                and self.heldout is not None else None)
        """Held-out gain growth per node, what the ``progress`` planner aims at
        (`core.dual.lagged_progress`)."""
        self.disagreement = (EnsembleDisagreement(self.bank, seed=int(self.bank.generator.initial_seed()) + 1)
                             if read.planner.aim == "disagreement" else None)
        """Per-node ensemble disagreement, what the ``disagreement`` planner aims at
        (`core.dual.disagreement`)."""
        self.goal_babbling = (GoalBabbling(seed=int(self.bank.generator.initial_seed()) + 2,
                                           only=read.planner.goals == "babbled")
                              if read.planner.babbles and self.itm is not None else None)
        """The aiming planner's babbled goals past the map's edge (`core.dual.goal_babbling`)."""
        self.unit = LatentScale(latent_dim, horizon=MODEL_SCALE_HORIZON)
        """The latent's running mean and RMS spread over a longer horizon (`LatentScale`): the local models'
        units (``world_models = repaired``) and the repaired r_int's unit."""
        self.sample_size = max(0, dual.model_batch - 1)
        """Older transitions of the node in each Eq. 5 step, beside the new one."""
        self.memory_size = max(self.sample_size, dual.model_memory) if self.sample_size else 0
        self._memory = (
            _NodeMemory(self.memory_size, latent_dim, action_dim, capacity) if self.memory_size else None
        )

    # ------------------------------------------------------------------ region coordinates
    def region_coordinates(self, phi: torch.Tensor | np.ndarray) -> np.ndarray | torch.Tensor:
        """What the ITM sees of a latent: φ itself, or φ / s with ``regions = repaired``."""
        return phi if self.scale is None else self.scale.normalise(phi)

    # ------------------------------------------------------------------ Alg. 2 lines 10-11
    def observe_state(self, phi: torch.Tensor) -> int:
        """Update the map with φ_t and return the best-matching node (0 for the global model)."""
        if self.itm is None:
            return 0
        if self.resolution is not None:
            self._set_resolution(self.resolution.observe(phi))
        if self.scale is not None:
            self.scale.observe(phi)
            if not self.scale.warm:  # no unit yet to place nodes in: one region until the scale is known
                return 0
        events = self.itm.update(self.region_coordinates(phi))
        self._follow(events)
        prune = self.config.region_prune_after
        if prune and self.itm.updates % PRUNE_EVERY == 0:
            pruned = self.itm.prune_idle(prune)
            if pruned:
                self._reset(list(pruned))
        return events.winner

    def _sync_model_space(self) -> None:
        """``world_models = repaired``: the models' unit s follows the latent's running RMS spread. They are
        not centred: a running mean moves with where the agent is, and would move what they have learnt
        (the intrinsic check's learnable regions lost their progress that way)."""
        if self.readings.world_models.normalised:
            self.bank.latent_scale = self.unit.scale
            if self.disagreement is not None:
                self.disagreement.follow_scale(self.unit.scale)

    def _follow(self, events: ItmEvents) -> None:
        if events.removed:
            self._reset(list(events.removed))
        if events.added:
            self.bank.reset_nodes(list(events.added), parents=list(events.parents))
            self._reset(list(events.added))  # after the bank: the lagged copies start as the new models

    def _set_resolution(self, distance: float | None) -> None:
        """Set the ITM's e_max to the L2 threshold `distance` (squared if the map compares squared ones)."""
        if distance is not None and self.itm is not None:
            self.itm.e_max = distance if self.itm.distance == "l2" else distance * distance

    def _reset(self, nodes: list[int]) -> None:
        """Every per-node state but the bank's, of new nodes or freed ones (a model is reset on reuse)."""
        self.lp.reset_nodes(nodes)
        if self.lagged_progress is not None:
            self.lagged_progress.reset_nodes(nodes)
        if self.disagreement is not None:
            self.disagreement.reset_nodes(nodes)
        if self._memory is not None:
            self._memory.reset(nodes)
        if self.heldout is not None:
            self.heldout.reset_nodes(nodes)

    def nearest(self, phi: torch.Tensor) -> int:
        """Best-matching node of a (predicted) latent without adapting the map (Alg. 1 line 5)."""
        if self.itm is None or not self.itm.initialised:
            return 0
        return int(self.itm.nearest(self.region_coordinates(phi))[0])

    def nearest_many(self, phi: torch.Tensor) -> np.ndarray:
        """Best-matching node of each row of ``phi [B, latent]`` (one batched distance computation)."""
        if self.itm is None or not self.itm.initialised:
            return np.zeros(phi.shape[0], dtype=np.int64)
        return self.itm.nearest(self.region_coordinates(phi))

    @property
    def num_nodes(self) -> int:
        return 1 if self.itm is None else self.itm.num_nodes

    # ------------------------------------------------------------------ Alg. 2 lines 22 and 25
    def learn_transition(
        self,
        node: int,
        phi: torch.Tensor,
        action: torch.Tensor,
        reward_ext: float,
        next_phi: torch.Tensor,
        terminated: bool = False,
    ) -> TransitionFeedback:
        """Eq. 8 error (before the update) → LP window of ``node``; one Eq. 5 step of ``node``'s model.

        With held-out reliability every ``HeldOut.every``-th transition of the node goes to its held-out set
        and the step uses the node's recent transitions only.
        """
        phi = phi.reshape(1, -1)
        action = torch.as_tensor(action, dtype=torch.float32).reshape(1, -1)
        next_phi = next_phi.reshape(1, -1)
        reward = torch.tensor([float(reward_ext)])
        done = torch.tensor([float(terminated)])
        held_out = self.heldout is not None and self.heldout.route_to_heldout(node)
        old = self._recent(node)
        if held_out:
            before = self.bank.predict(torch.tensor([node]), phi, action)
            error = float(self.bank.errors(before.next_latent, before.reward, next_phi, reward)[0])
            self.heldout.add(node, phi, action, float(reward_ext), next_phi)
            if old is not None:
                self.bank.update(torch.full((old[0].shape[0],), node, dtype=torch.int64), old[0], old[1],
                                 old[3], old[2], old[4])
        else:
            if old is not None:
                count = old[0].shape[0]
                errors = self.bank.update(
                    torch.full((count + 1,), node, dtype=torch.int64),
                    torch.cat([phi, old[0]]), torch.cat([action, old[1]]),
                    torch.cat([next_phi, old[3]]), torch.cat([reward, old[2]]), torch.cat([done, old[4]]),
                )
            else:
                errors = self.bank.update(torch.tensor([node]), phi, action, next_phi, reward, done)
            error = float(errors[0])
            if self._memory is not None:
                self._memory.add(node, phi[0], action[0], float(reward_ext), next_phi[0], float(terminated))
        stepped = old is not None or not held_out  # the node's model took an Eq. 5 step
        self.lp.record([node], [error])
        if self.disagreement is not None:
            self.disagreement.record_and_learn(node, phi, action, float(reward_ext), next_phi)
        if self.lagged_progress is not None:
            self.lagged_progress.record(node)
            if stepped:
                self.lagged_progress.after_update([node])
        if self.heldout is not None:
            no_change = float(self.bank.errors(phi, torch.zeros(1), next_phi, reward)[0])
            self.heldout.record(node, error, no_change)
        self.unit.observe(phi[0])
        self._sync_model_space()
        if self.heldout is not None and stepped:
            self.heldout.after_update([node])
        return TransitionFeedback(error=error, intrinsic_reward=self.intrinsic_reward(node, next_phi))

    def _recent(self, node: int) -> tuple[torch.Tensor, ...] | None:
        """Up to ``model_batch − 1`` of the node's stored transitions: the newest (``model_memory`` 0), or a
        uniform sample of the ``model_memory`` newest (drawn with the bank's generator)."""
        if self._memory is None or self._memory.count(node) == 0:
            return None
        stored = self._memory.get(node)
        count = stored[0].shape[0]
        if count <= self.sample_size:
            return stored
        rows = torch.randperm(count, generator=self.bank.generator)[: self.sample_size]
        return tuple(column[rows] for column in stored)

    def intrinsic_rewards(self, nodes: np.ndarray, next_phi: torch.Tensor) -> np.ndarray:
        """`intrinsic_reward` of many transitions: from regions ``nodes [k]`` to ``next_phi [k, latent]``."""
        intrinsic = self.readings.intrinsic
        regions = self.nearest_many(next_phi) if intrinsic.at_destination else nodes
        rewards = self.region_intrinsic_rewards(regions)
        if intrinsic.centred:
            rewards = rewards - self.region_intrinsic_rewards(self.alive_regions()).mean()
        return rewards

    def region_intrinsic_rewards(self, regions: np.ndarray) -> np.ndarray:
        """The r_int signal of each region in ``regions`` now, before any centring: −c·LP (paper), or
        +c·held-out progress / s (repaired)."""
        if self.readings.intrinsic.from_lp:
            return self.lp.intrinsic_reward(regions)
        assert self.heldout is not None
        unit = self.unit.scale**2 if self.readings.reliability.squared else self.unit.scale
        return self.config.intrinsic_scale * self.heldout.progress_of(regions) / unit

    def aim_goal(self, aim: str, node: int | None = None,
                 phi: torch.Tensor | None = None) -> RegionGoal | None:
        """The planner's aim (``dual.planner``'s `Planner.aim`) as a goal on the map: one value per live
        region (`aim_values`) at the region's node in the map's coordinates, the goal where those values,
        averaged over the map's neighbours, peak (`RegionGoal`). With ``node``, the plan's start node, the
        goal carries that node's action map (`action_map`), through which a plan's pull is predicted. With
        ``phi``, the latent a decision is made at (one call per decision: `MetaController`), a reading that
        babbles may redirect the goal past the map's edge (`GoalBabbling.choose`). None without a map, before
        its first state, or no aim."""
        if aim == "none" or self.itm is None or not self.itm.initialised:
            return None
        regions = self.itm.alive_ids()
        map_unit = None if self.scale is None else float(self.scale.scale)
        action_map = None if node is None else self.action_map(node)
        values = self.aim_values(aim, regions)
        goal = RegionGoal(self.itm.weights(regions), values, unit=map_unit, action_map=action_map,
                          adjacency=self.itm.adjacency(regions))
        if phi is None or self.goal_babbling is None:
            return goal
        resolution = self.itm.e_max if self.itm.distance == "l2" else float(np.sqrt(self.itm.e_max))
        u = phi.detach().double().reshape(-1).numpy() / goal.unit
        return self.goal_babbling.choose(goal, u, resolution)

    def aim_values(self, aim: str, regions: np.ndarray) -> np.ndarray:
        """Each region's value for an aim: `LaggedProgress.progress` (progress),
        `EnsembleDisagreement.relative` (disagreement) or `HeldOutReliability.relative_error` (novelty)."""
        if aim == "progress":
            assert self.lagged_progress is not None
            return self.lagged_progress.progress(regions)
        if aim == "disagreement":
            assert self.disagreement is not None
            return self.disagreement.relative(regions, self.unit.scale)
        assert self.heldout is not None
        return self.heldout.relative_error(regions)

    def stored_transitions(self, node: int) -> int:
        """How many of the node's real transitions are stored for its Eq. 5 minibatches and its action map (0
        without a memory)."""
        return 0 if self._memory is None else self._memory.count(node)

    def action_map(self, node: int) -> ActionMap | None:
        """The linear latent dynamics at ``node`` (`core.dual.action_map.fit_action_map` over its stored real
        transitions), through which an aiming plan predicts its latents; None with too few transitions or
        nothing moved."""
        if self._memory is None:
            return None
        latent, action, _, next_latent, _ = self._memory.get(node)
        return fit_action_map(latent, action, next_latent)

    def alive_regions(self) -> np.ndarray:
        """The live regions' ids (node 0 alone without a map, or before the map's first state)."""
        if self.itm is None or not self.itm.initialised:
            return np.zeros(1, dtype=np.int64)
        return self.itm.alive_ids()

    def intrinsic_reward(self, node: int, next_phi: torch.Tensor) -> float:
        """r_int of a transition from region ``node`` to latent ``next_phi`` (Alg. 2 line 22, or the repair).

        `Intrinsic.region`: source → the LP of ``node``; destination → the LP of the region ``next_phi``
        falls in (the consequence of the action). `Intrinsic.signal`: neg_lp → −c·LP (Eq. 9, released
        normalisation); neg_lp_centred → −c·LP minus its mean over the live regions (the step-cost part of
        the literal r_int removed, its state dependence kept); progress → +c·(held-out progress) / s, s the
        latent's RMS spread (`unit`; squared with squared Eq. 8 errors).
        """
        return float(self.intrinsic_rewards(np.array([node], dtype=np.int64), next_phi.reshape(1, -1))[0])

    def learn_batch(
        self, phi: torch.Tensor, action: torch.Tensor, reward_ext: torch.Tensor, next_phi: torch.Tensor
    ) -> torch.Tensor:
        """One Eq. 5 step of the global model (node 0) on a minibatch; returns the pre-update errors (MVE)."""
        for row in phi:
            self.unit.observe(row)
        self._sync_model_space()
        nodes = torch.zeros(phi.shape[0], dtype=torch.int64)
        errors = self.bank.update(nodes, phi, action, next_phi, reward_ext)
        return errors

    def refit(
        self,
        phi: torch.Tensor,
        action: torch.Tensor,
        reward_ext: torch.Tensor,
        next_phi: torch.Tensor,
        terminated: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """One Eq. 5 step of each node a batch of re-encoded real transitions touches (``dual.refit_every``).

        Each sample goes to its nearest node (the map is not adapted, as in Alg. 1 line 5); each touched
        node takes one Adam step on the mean loss of its samples. The learning-progress windows are left
        alone: they hold the errors of the real transitions as they arrived; the held-out verdicts of the
        touched nodes are re-judged. Returns the pre-update Eq. 8 errors ``[B]``, i.e. how far the models had
        drifted from the current encoder's latents.
        """
        nodes = torch.from_numpy(self.nearest_many(phi))
        errors = self.bank.update(nodes, phi, action, next_phi, reward_ext, terminated)
        if self.heldout is not None:
            self.heldout.evaluate(torch.unique(nodes).numpy())
        if self.lagged_progress is not None:
            self.lagged_progress.after_update(nodes.numpy())
        return errors

    # ------------------------------------------------------------------ queries
    def reliable(self, node: int) -> bool:
        """Section 2.3.2's test: LP_{t,n} ≥ 0 (paper) or the held-out verdict (``reliability = repaired``)."""
        return bool(self.reliable_many(np.array([node]))[0])

    def reliable_many(self, nodes: np.ndarray) -> np.ndarray:
        """`reliable` for an array of nodes (vectorised)."""
        if self.readings.reliability.held_out:
            assert self.heldout is not None
            return self.heldout.is_trusted(nodes)
        return self.lp.reliable(nodes)

    def imagination_share(self, nodes: np.ndarray) -> np.ndarray:
        """Probability of keeping an imagined transition each node predicted (``dual.imagination``)."""
        if not self.readings.imagination.gated or self.heldout is None:
            return np.ones(np.asarray(nodes).shape[0])
        return self.heldout.share(nodes, self.config.imagination_max_ratio)

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
        if self.scale is not None:
            state["scale"] = self.scale.state_dict()
        if self.heldout is not None:
            state["heldout"] = self.heldout.state_dict()
        if self.lagged_progress is not None:
            state["lagged_progress"] = self.lagged_progress.state_dict()
        if self.disagreement is not None:
            state["disagreement"] = self.disagreement.state_dict()
        if self.goal_babbling is not None:
            state["goal_babbling"] = self.goal_babbling.state_dict()
        state["generator"] = {"state": self.bank.generator.get_state()}
        state["unit"] = self.unit.state_dict()
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
        if self.scale is not None:
            self.scale.load_state_dict(state["scale"])
        self.unit.load_state_dict(state["unit"])
        self._sync_model_space()
        if self.heldout is not None:
            self.heldout.load_state_dict(state["heldout"])
        if self.lagged_progress is not None:
            self.lagged_progress.load_state_dict(state["lagged_progress"])
        if self.disagreement is not None:
            self.disagreement.load_state_dict(state["disagreement"])
        if self.goal_babbling is not None and "goal_babbling" in state:  # absent: a checkpoint from before it
            self.goal_babbling.load_state_dict(state["goal_babbling"])
        self.bank.generator.set_state(state["generator"]["state"])


class _NodeMemory:
    """Each node's last ``size`` real transitions, stacked ``[capacity, size, ...]`` (for ``model_batch``)."""

    def __init__(self, size: int, latent_dim: int, action_dim: int, capacity: int) -> None:
        self.size = size
        self.latent = np.zeros((capacity, size, latent_dim), dtype=np.float32)
        self.action = np.zeros((capacity, size, action_dim), dtype=np.float32)
        self.reward = np.zeros((capacity, size), dtype=np.float32)
        self.next_latent = np.zeros((capacity, size, latent_dim), dtype=np.float32)
        self.terminated = np.zeros((capacity, size), dtype=np.float32)
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
        self.terminated = np.concatenate([self.terminated, np.zeros((pad, self.size), np.float32)])
        self.written = np.concatenate([self.written, np.zeros(pad, np.int64)])

    def count(self, node: int) -> int:
        self._grow(node)
        return int(min(self.written[node], self.size))

    def get(self, node: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """(φ, a, r, φ′, terminated) of the node's stored transitions."""
        n = self.count(node)
        return (torch.from_numpy(self.latent[node, :n]), torch.from_numpy(self.action[node, :n]),
                torch.from_numpy(self.reward[node, :n]), torch.from_numpy(self.next_latent[node, :n]),
                torch.from_numpy(self.terminated[node, :n]))

    def add(self, node: int, latent: torch.Tensor, action: torch.Tensor, reward: float,
            next_latent: torch.Tensor, terminated: float = 0.0) -> None:
        self._grow(node)
        slot = int(self.written[node] % self.size)
        self.latent[node, slot] = latent.numpy()
        self.action[node, slot] = action.numpy()
        self.reward[node, slot] = reward
        self.next_latent[node, slot] = next_latent.numpy()
        self.terminated[node, slot] = terminated
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
                "terminated": torch.from_numpy(self.terminated.copy()),
                "written": torch.from_numpy(self.written.copy())}

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self.latent = state["latent"].numpy().copy()
        self.action = state["action"].numpy().copy()
        self.reward = state["reward"].numpy().copy()
        self.next_latent = state["next_latent"].numpy().copy()
        if "terminated" in state:
            self.terminated = state["terminated"].numpy().copy()
        else:  # written before the termination head existed
            self.terminated = np.zeros(self.reward.shape, dtype=np.float32)
        self.written = state["written"].numpy().copy()
