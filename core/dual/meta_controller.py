"""The intrinsically motivated meta-controller: reliability-based arbitration (Section 2.3.2, Alg. 2, 12-19).

At each step, with φ_t and its best-matching node n:

- reliable (`LocalWorldModels.reliable`: LP_{t,n} ≥ 0, or the held-out verdict of ``dual.reliability``) →
  model-based: the adaptive rollout of Alg. 1 (continue while the node of the current latent is reliable)
  sets the horizon H, the rollout's actor actions are the initial plan,
  K gradient steps on L_plan (Eq. 6-7, `core.dual.planning.optimise_plan`; with an aiming planner, minus
  c · the aim's pull, `LocalWorldModels.aim_goal`, at the latents node n's action map predicts) give
  â^(K), whose first action is returned;
- otherwise, with an aiming planner whose goal exists and whose start node has an action map → steered: the
  actor's actions along the latents the action map predicts, moved by K steps toward the goal alone
  (`core.dual.planning.steer_plan`; no predicted reward, no rollout for imagination). Why: gated by the
  models' reliability, an aim steered only where the models were already learnt — on the controlled check
  the planner acted on 0.09-0.49 of steps by seed, and the seeds that planned least went to the learnable
  third least though their goal lay there (docs/dual-system.md, item 16);
- otherwise → model-free: μ(φ_t).

Exploration noise is the caller's job (Alg. 2 line 20), as is storing the rollout's imagined
transitions (I2A, Alg. 3 line 17).

``fixed_horizon=H`` turns the adaptive depth into the fixed-horizon MPC of DDPG+CMC: the rollout
always runs H steps with the (single, global) model, arbitration still by LP ≥ 0. A rollout of depth
0 (D_max = 0 or H = 0) falls back to the model-free action.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from core.config import DualConfig
from core.dual.planning import (
    ActorFn,
    PlanResult,
    Rollout,
    TerminalValue,
    model_rollout,
    optimise_plan,
    steer_plan,
)
from core.dual.region_goal import RegionGoal
from core.dual.world_models import LocalWorldModels


@dataclass(frozen=True)
class MetaDecision:
    """One meta-control decision: the action before noise, which system chose it, and the rollout/plan."""

    action: torch.Tensor
    """``[action_dim]``, before exploration noise."""
    model_based: bool
    rollout: Rollout | None = None
    """The model rollout (adaptive or fixed length) when model-based; its rows are imagined transitions."""
    plan: PlanResult | None = None
    aim: RegionGoal | None = None
    """The aiming planner's goal the plan was pulled toward (None: no aim entered the plan)."""

    @property
    def steered(self) -> bool:
        """Steered by an aiming planner's goal alone (model-based without a rollout, `steer_plan`)."""
        return self.model_based and self.rollout is None


class MetaController:
    """Alg. 2 lines 12-19 over a `LocalWorldModels` (adaptive depth) or a global model (fixed horizon)."""

    def __init__(self, world: LocalWorldModels, dual: DualConfig, fixed_horizon: int | None = None) -> None:
        if fixed_horizon is not None and fixed_horizon < 0:
            raise ValueError(f"fixed horizon must be >= 0, got {fixed_horizon}")
        self.world = world
        self.config = dual
        self.planner = world.readings.planner
        """Eq. 6-7's reading: the world models' readings, resolved once where the dual system is built."""
        self.fixed_horizon = fixed_horizon

    def rollout(self, phi: torch.Tensor, node: int, actor: ActorFn) -> Rollout:
        """Alg. 1's adaptive-length rollout, or a fixed-horizon one (CMC)."""
        world = self.world
        if self.fixed_horizon is not None:
            return model_rollout(phi, node, world.bank, actor, self.fixed_horizon,
                                 continue_at=lambda _i, _n: True, locate=world.nearest)
        # Alg. 1: the regions' reliability and matching go through the world (its region coordinates).
        return model_rollout(phi, node, world.bank, actor, self.config.d_max,
                             continue_at=lambda _i, n: world.reliable(n), locate=world.nearest)

    @torch.no_grad()
    def decide(self, phi: torch.Tensor, node: int, actor: ActorFn,
               terminal: TerminalValue | None = None) -> MetaDecision:
        """Model-based (rollout + gradient MPC) when LP_{t,n} ≥ 0; else, with an aiming planner and a goal,
        steered toward it (`steer_plan`); else μ(φ_t). ``terminal``: the learner's value at the plan's end,
        used by a planner whose reading has ``terminal`` (none given: the plan ends at its last reward)."""
        phi = phi.reshape(1, -1)
        if self.world.reliable(node):
            rollout = self.rollout(phi, node, actor)
            if rollout.depth > 0:
                cfg = self.config
                aim = self.world.aim_goal(self.planner.aim, node, phi)
                plan = optimise_plan(phi, rollout, self.world.bank, self.planner, steps=cfg.plan_steps,
                                     lr=cfg.plan_lr, r_star=cfg.r_star, aim=aim,
                                     aim_scale=cfg.intrinsic_scale,
                                     terminal=terminal if self.planner.terminal else None)
                return MetaDecision(action=plan.action, model_based=True, rollout=rollout, plan=plan,
                                    aim=aim if aim is not None and aim.goal is not None else None)
        if self.planner.aim != "none" and self.fixed_horizon is None:
            aim = self.world.aim_goal(self.planner.aim, node, phi)
            if aim is not None and aim.goal is not None and aim.action_map is not None:
                cfg = self.config
                plan = steer_plan(phi, actor, aim, self.planner, horizon=cfg.d_max, steps=cfg.plan_steps,
                                  lr=cfg.plan_lr)
                return MetaDecision(action=plan.action, model_based=True, plan=plan, aim=aim)
        return MetaDecision(action=actor(phi)[0], model_based=False)
