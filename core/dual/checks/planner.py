"""Check: gradient MPC moves the plan toward higher return (Eq. 6-7; ``dual.planner``,
``dual.plan_lr``, ``dual.plan_steps``).

Purpose (Section 2.2): starting from the actor's plan, K gradient steps on L_plan should give a plan whose
return is higher, by enough to matter beside the exploration noise added afterwards (Alg. 2 line 20). In
issue #19's grasp runs the executed action moved by 0.0003 on average (K = 10, α = 1e-3).

The toy has a known differentiable model written as a bank model (`true_model`): φ ∈ R², a ∈ [−1, 1]²,
φ′ = φ + 0.2·tanh(a) (a delta model whose first two hidden units are tanh(a)), and a reward that is a sum of
eight random tanh bumps of (φ, a), shifted into [−1, 0] so that L_plan = (R* − Σ r̂)² with R* = 1 always asks
for more return. From 200 start states φ ~ U[−1, 1]², a fixed random actor μ(φ) = tanh(W φ + b) proposes a
plan over H = 3 steps (`core.dual.planning.model_rollout`), and `core.dual.planning.optimise_plan` optimises
it with the profile's settings, once with the true model and once with a model the bank learnt (through
`LocalWorldModels`, the profile's model options) from 3000 random transitions of the toy. Figures, for each
model:

- ``toward_reward_share``: share of starts where executing the optimised plan in the true toy returns more
  than executing the actor's plan;
- ``shift_over_noise_std``: mean max-abs change of the executed first action, divided by the exploration
  noise's initial std (``agent.noise_std``).

The JSON reports the smaller of the two models' figures (both must reach the goals).
"""

from __future__ import annotations

import numpy as np
import torch

from core.config import Config, DualConfig
from core.dual.model_bank import ModelBank
from core.dual.planning import model_rollout, optimise_plan
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels

LATENT, ACTIONS, HIDDEN, BUMPS, HORIZON = 2, 2, 20, 8, 3


def true_model(seed: int) -> ModelBank:
    """The toy's dynamics and reward as a one-node delta bank (module docstring)."""
    g = torch.Generator().manual_seed(seed)
    bank = ModelBank(latent_dim=LATENT, action_dim=ACTIONS, hidden=HIDDEN, initial_capacity=1, target="delta",
                     generator=g)
    p = bank.params
    for name in p:
        p[name].zero_()
    w1 = p["w1"][0]  # [in, hidden]
    for k in range(ACTIONS):  # hidden unit k = tanh(a_k); Δφ_k = 0.2·that unit
        w1[LATENT + k, k] = 1.0
        p["wm"][0][k, k] = 0.2
    bumps = slice(ACTIONS, ACTIONS + BUMPS)
    w1[:, bumps] = torch.randn((LATENT + ACTIONS, BUMPS), generator=g) * 1.5
    p["b1"][0][bumps] = torch.randn(BUMPS, generator=g) * 0.5
    heights = torch.rand(BUMPS, generator=g) * 0.2 + 0.05
    p["wr"][0][bumps, 0] = heights * torch.sign(torch.randn(BUMPS, generator=g))
    p["br"][0][0] = -float(heights.sum())  # every reward in [−2Σh, 0]: Σ r̂ < R* = 1
    return bank


def learned_model(dual: DualConfig, truth: ModelBank, transitions: int, seed: int) -> ModelBank:
    """A one-region `LocalWorldModels` (the profile's model options) trained on random toy transitions."""
    generator = torch.Generator().manual_seed(seed)
    world = LocalWorldModels(dual, LATENT, ACTIONS, regions=False, generator=generator,
                             readings=resolve(dual))
    g = torch.Generator().manual_seed(seed + 1)
    phi = torch.rand(transitions, LATENT, generator=g) * 2 - 1
    action = torch.rand(transitions, ACTIONS, generator=g) * 2 - 1
    outcome = truth.predict(torch.zeros(transitions, dtype=torch.int64), phi, action)
    for t in range(transitions):
        world.learn_transition(0, phi[t], action[t], float(outcome.reward[t]), outcome.next_latent[t])
    return world.bank


def true_return(truth: ModelBank, phi: torch.Tensor, plan: torch.Tensor) -> float:
    """Σ_h r_h of executing ``plan`` open loop in the toy from φ (actions clipped to [−1, 1] like an env)."""
    total, current = 0.0, phi.reshape(1, -1)
    for action in plan.clamp(-1.0, 1.0):
        step = truth.predict(torch.zeros(1, dtype=torch.int64), current, action.reshape(1, -1))
        total += float(step.reward[0])
        current = step.next_latent
    return total


def plan_figures(dual: DualConfig, noise_std: float, model: ModelBank, truth: ModelBank, starts: int,
                 seed: int) -> dict[str, float]:
    """toward_reward_share and shift_over_noise_std of planning with ``model`` (module docstring)."""
    g = torch.Generator().manual_seed(seed + 2)
    actor = torch.nn.Sequential(torch.nn.Linear(LATENT, ACTIONS), torch.nn.Tanh())
    with torch.no_grad():
        actor[0].weight.copy_(torch.randn((ACTIONS, LATENT), generator=g))
        actor[0].bias.copy_(torch.randn(ACTIONS, generator=g) * 0.5)
    toward, shifts = [], []
    planner = resolve(dual).planner
    for phi in torch.rand(starts, LATENT, generator=g) * 2 - 1:
        with torch.no_grad():
            rollout = model_rollout(phi, 0, model, actor, HORIZON, continue_at=lambda _i, _n: True,
                                    locate=lambda _latent: 0)
        result = optimise_plan(phi, rollout, model, planner, steps=dual.plan_steps, lr=dual.plan_lr,
                               r_star=dual.r_star)
        toward.append(true_return(truth, phi, result.plan) > true_return(truth, phi, rollout.actions))
        shifts.append(float((result.action - rollout.actions[0].clamp(-1.0, 1.0)).abs().max()))
    return {"toward_reward_share": float(np.mean(toward)),
            "shift_over_noise_std": float(np.mean(shifts)) / noise_std}


def planner_check(
    config: Config, starts: int = 200, transitions: int = 3000, seed: int = 0
) -> dict[str, float]:
    """The JSON figures: the smaller of the true model's and the learnt model's (module docstring)."""
    dual = config.dual
    truth = true_model(seed)
    figures = [plan_figures(dual, config.agent.noise_std, model, truth, starts, seed)
               for model in (truth, learned_model(dual, truth, transitions, seed))]
    return {key: round(min(f[key] for f in figures), 3) for key in figures[0]}
