"""Goal babbling beside the aim: a share of an aiming planner's goals drawn past the edge of the map.

An aiming planner's goal (`core.dual.region_goal.RegionGoal`) is a node of the ITM where the regions' values
peak, and the map grows only where the agent has been. From a fixed start the aim therefore points back into
the area the agent already knows: on the noisy TV's fixed-start check (`python -m
core.dual.checks.planner_aim fixed`, the planner alone on `core.envs.noisy_tv.NoisyTVEnv`, tuning seeds
100-104, 20k steps) the progress planner of 63a3ecb covered 0.39 of the cells outside the noise over the late
half against a random walk's 0.64, lower in 4 of 5 seeds (docs/dual-system.md, items 19-20). In the loop it
covered no more than SAC alone.

Intrinsically motivated goal exploration (SAGG-RIAC, Baranes & Oudeyer 2013; IMGEP, Forestier et al. 2022)
mixes the goals chosen by progress with goals drawn at random in the goal space, which is what lets the
explored part of that space grow past what has been reached. Here the goal space is the map's own
coordinates u (φ, or φ / s with a normalised map), bounded by where the map has nodes:

- every `PATIENCE` decisions the planner picks its next goal: with probability `SHARE` a point drawn
  uniformly in the bounding box of the map's nodes widened by `REACH` · e_max on every side — so the draws
  reach past where the edge nodes' regions already reach (about e_max), and the box widens as the map grows
  into it — and otherwise the aim's own goal (recomputed at every decision, as before);
- a babbled goal is held until the agent is within e_max of it or the next pick;
- its pull length is the aim's (the values' contrast w, `RegionGoal.weight`) floored at `FLOOR`, so a babbled
  goal pulls also where the aim has no contrast (all values equal, e.g. 0 before anything is learnt): there
  the aim's own goal is nothing, and a babbled one is the only thing that moves the agent past the map.

Until item 21 of docs/dual-system.md (a5ecd29) the box was widened by one e_max and a babbled goal took the
aim's w with no floor, so it acted only while the aim had a contrast. On the noisy TV's fixed-start check a
probe with the floor covered more than that rule on 9 of 10 tuning seeds (item 20), and in the loop babbled
decisions were rare (0-29 of an episode's 200).

The ``babbling`` planner reading keeps the babbled goals and removes the aim's own (between babbled goals
nothing is aimed at and the actor acts, or the plan seeks the predicted return alone): the ablation that
tells whether progress, rather than babbling, does the work.

`SHARE` (0.2) and `PATIENCE` (50 decisions) were set before any figure of this design was looked at and are
not tuned: the share is of the order IMGEP implementations give random goals, the patience a quarter of the
noisy TV's episode. `FLOOR` is item 20's prototype's; `REACH` the step item 20 named (item 21 measures
it). Its draws come from a generator of its own (seeded from the world's), checkpointed with the world
models.
"""

from __future__ import annotations

import numpy as np
import torch

from core.dual.region_goal import RegionGoal

SHARE = 0.2
"""Probability that a pick is a babbled goal (else the aim's goal)."""

PATIENCE = 50
"""Decisions between picks; a babbled goal is held at most this long."""

REACH = 2.0
"""How far past the map's nodes a goal may be drawn, in e_max."""

FLOOR = 1e-3
"""The babbled pull's least length w, in map units (the aim's contrast where it is larger)."""


class GoalBabbling:
    """The babbled goal of the module docstring: ``choose(aim, u, margin)`` once per decision."""

    def __init__(self, seed: int, share: float = SHARE, patience: int = PATIENCE, only: bool = False,
                 reach: float = REACH) -> None:
        if not 0.0 <= share <= 1.0 or patience < 1 or reach < 0.0:
            raise ValueError("share must be in [0, 1], patience >= 1 and reach >= 0, got "
                             f"{share}, {patience}, {reach}")
        self.only = only
        """Only babbled goals: between them no goal at all (the ``babbling`` reading, the ablation)."""
        self.share = float(share)
        self.patience = int(patience)
        self.reach = float(reach)
        self.generator = torch.Generator().manual_seed(int(seed))
        self.decisions = 0
        """Decisions so far (a pick at every multiple of `patience`)."""
        self.goal: np.ndarray | None = None
        """The babbled goal held now, in map coordinates (None: the aim's own goal)."""
        self.picks = 0
        """Babbled goals drawn so far."""
        self.dropped_at_once = 0
        """Of them, those drawn within e_max of the agent (so reached, and dropped, at once)."""

    def choose(self, aim: RegionGoal, u: np.ndarray, margin: float) -> RegionGoal:
        """The goal for this decision: ``aim`` itself, or ``aim`` redirected to the babbled goal; ``u`` the
        agent's position in map coordinates, ``margin`` e_max in map units."""
        drawn = False
        if self.decisions % self.patience == 0:
            dims = aim.centres.shape[1]
            draws = torch.rand(1 + dims, generator=self.generator, dtype=torch.float64).numpy()
            babble, point = float(draws[0]), draws[1:]
            self.goal = None
            if babble < self.share and aim.centres.shape[0] > 0:
                widening = self.reach * margin
                low, high = aim.centres.min(axis=0) - widening, aim.centres.max(axis=0) + widening
                self.goal, drawn = low + (high - low) * point, True
                self.picks += 1
        self.decisions += 1
        position = np.asarray(u, dtype=np.float64).reshape(-1)
        if self.goal is not None and float(np.linalg.norm(position - self.goal)) < margin:
            self.goal = None
            self.dropped_at_once += int(drawn)
        if self.goal is not None:
            return aim.redirected(self.goal, weight=max(aim.weight, FLOOR))
        if self.only and aim.goal is not None:
            return aim.redirected(None)
        return aim

    def state_dict(self) -> dict[str, torch.Tensor]:
        empty = torch.zeros(0, dtype=torch.float64)
        goal = empty if self.goal is None else torch.from_numpy(self.goal.copy())
        return {"decisions": torch.tensor(self.decisions), "goal": goal,
                "generator": self.generator.get_state(), "picks": torch.tensor(self.picks),
                "dropped_at_once": torch.tensor(self.dropped_at_once)}

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        self.decisions = int(state["decisions"])
        goal = state["goal"].numpy().astype(np.float64)
        self.goal = goal if goal.size else None
        self.generator.set_state(state["generator"])
        self.picks = int(state.get("picks", 0))  # absent: a checkpoint from before item 21
        self.dropped_at_once = int(state.get("dropped_at_once", 0))
