"""Model-based control: the model rollout of Algorithm 1 and gradient MPC (Eq. 6-7).

`model_rollout` rolls the actor μ and the local world models out from φ_t: before each step a stopping rule
reads the node the current (predicted) latent falls in (Alg. 1: go on while that node is reliable, at most
D_max steps; `core.dual.meta_controller.MetaController.rollout`), and otherwise predicts
(â_i, r̂_i, φ̂_{i+1}) with that node's model. The rollout it returns is both the horizon H = i − t (Alg. 1
line 8) and the imagined transitions (φ_i, â_i, r̂_i, φ̂_{i+1}) that I2A may store in B_latent (Alg. 3
lines 13-21, `core.dual.imagination`).

`optimise_plan` takes the rollout's actions as the initial plan â^(0) and performs K steps of plain
gradient descent (Eq. 7) with α_plan on

- ``objective="sum"``: L_plan = (R* − Σ_h r̂_h)² (Eq. 6, paper text), or
- ``objective="per_step"``: L_plan = ½ Σ_h (R* − r̂_h)² (authors' code, with R* = 1 there),

re-predicting the latents φ̂_{h+1} = M_{n_h}(φ̂_h, â_h) through the local models at every step while
the models' weights stay fixed. Decision: the model used at plan step h is that of the node n_h the
rollout visited (Alg. 1's choice), held fixed during the K steps so the objective stays
differentiable. The gradient is back-propagated through time by hand (closed-form derivatives of
the one-hidden-layer tanh models, `LocalModel` in dual/model_bank.py: the bank's forward pass and chain rule),
which costs a few dozen small matrix products instead of an autograd graph per step; the tests compare it with
autograd through the same forward pass.

Agents act in a normalised action space, [−1, 1]^d (the environment boundary rescales), so the plan's bounds
are [−1, 1]. The planner's reading (``dual.planner``, `core.dual.readings.Planner`) selects the objective
(`OBJECTIVES`) and the step (`STEPS`) once per plan (docs/dual-system.md, "Planner"):

- ``optimiser="sgd"``, ``clip="executed"`` (paper): plain steps of α_plan; only the executed first action
  is clipped to the bounds;
- ``optimiser="normalised"``: the gradient scaled to length α over the whole plan (α in action units), and
  ``clip="every_step"``: every action of the plan is projected onto the bounds after every step (projected
  gradient descent), so the later steps of the plan are optimised for actions that can be executed.

A reading with ``terminal`` (the aiming planners since item 23 of docs/dual-system.md) adds the learner's
value where the plan ends, γ^H V(φ̂_H) (`TerminalValue`), to the predicted return: the back-propagation
through the models starts from its gradient instead of 0.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from core.dual.model_bank import ModelBank
from core.dual.readings import Planner
from core.dual.region_goal import RegionGoal

ActorFn = Callable[[torch.Tensor], torch.Tensor]
ObjectiveFn = Callable[[np.ndarray, float], tuple[float, np.ndarray]]
"""L_plan of the plan's predicted rewards r̂ ``[H]`` and R*: (loss, dL/dr̂ ``[H]``)."""
StepFn = Callable[[np.ndarray, np.ndarray, float], None]
"""One Eq. 7 step on the plan ``[H, action]`` (in place) from its gradient, with α."""


@dataclass(frozen=True)
class TerminalValue:
    """The learner's value at the plan's end, γ^H V(φ̂_H), added to the predicted return (planners whose
    reading has ``terminal``; docs/dual-system.md, item 23): the objective of value-guided MPC with an
    off-policy learner (LOOP, Sikchi et al. CoRL 2021; TD-MPC, Hansen et al. ICML 2022)."""

    value: Callable[[np.ndarray], tuple[float, np.ndarray]]
    """φ ``[latent]`` (float64) → (V(φ) = min_i Q_i(φ, μ(φ)), ∇_φ V ``[latent]``), through critic and μ."""
    discount: float
    """γ: the value H steps ahead counts γ^H."""

    def linearised(self) -> TerminalValue:
        """V's first-order expansion at the first latent it is read at, V(φ₀) + ∇V(φ₀)·(φ − φ₀): what
        `optimise_plan` reads during its K steps, so the learner's networks run once per plan (as the local
        models' weights, V is held fixed while the plan moves; at the first step it is exact)."""
        return TerminalValue(_FirstOrder(self.value), self.discount)


class _FirstOrder:
    """A value function's first-order expansion at the first point it is called at."""

    def __init__(self, value: Callable[[np.ndarray], tuple[float, np.ndarray]]) -> None:
        self.value = value
        self.anchor: tuple[np.ndarray, float, np.ndarray] | None = None

    def __call__(self, latent: np.ndarray) -> tuple[float, np.ndarray]:
        if self.anchor is None:
            value, grad = self.value(latent)
            self.anchor = (np.array(latent, dtype=np.float64), float(value), np.asarray(grad, np.float64))
        at, value, grad = self.anchor
        return value + float(grad @ (latent - at)), grad


def sum_objective(rewards: np.ndarray, r_star: float) -> tuple[float, np.ndarray]:
    """Eq. 6 as printed: L_plan = (R* − Σ_h r̂_h)²."""
    residual = r_star - rewards.sum()
    return residual * residual, np.full(rewards.shape[0], -2.0 * residual)


def per_step_objective(rewards: np.ndarray, r_star: float) -> tuple[float, np.ndarray]:
    """The released code's L_plan = ½ Σ_h (R* − r̂_h)² (R* = 1 there)."""
    residual = r_star - rewards
    return 0.5 * float(residual @ residual), -residual


def return_objective(rewards: np.ndarray, r_star: float) -> tuple[float, np.ndarray]:
    """The aiming planners' extrinsic part: L_plan = −Σ_h r̂_h, the predicted return maximised (R* unused: a
    target return would push the plan away from rewards above it)."""
    return -float(rewards.sum()), np.full(rewards.shape[0], -1.0)


def sgd_step(plan: np.ndarray, grad: np.ndarray, lr: float) -> None:
    """Eq. 7 as printed: â ← â − α ∇L_plan."""
    plan -= lr * grad


def normalised_step(plan: np.ndarray, grad: np.ndarray, lr: float) -> None:
    """The repaired step: the gradient scaled to length α over the whole plan (a step in action units)."""
    norm = float(np.sqrt((grad * grad).sum()))
    if norm > 0.0:
        plan -= lr * grad / norm


OBJECTIVES: dict[str, ObjectiveFn] = {"sum": sum_objective, "per_step": per_step_objective,
                                      "return": return_objective}
"""`Planner.objective` → its L_plan."""
STEPS: dict[str, StepFn] = {"sgd": sgd_step, "normalised": normalised_step}
"""`Planner.optimiser` → its Eq. 7 step."""


@dataclass(frozen=True)
class Rollout:
    """Alg. 1's adaptive-length rollout; row i is the imagined transition (φ_i, â_i, r̂_i, φ̂_{i+1})."""

    latents: torch.Tensor
    """φ_i ``[H, latent]`` (row 0 is the real φ_t)."""
    actions: torch.Tensor
    """â_i = μ(φ_i) ``[H, action]``."""
    rewards: torch.Tensor
    """r̂_i = R_{n_i}(φ_i, â_i) ``[H]``."""
    next_latents: torch.Tensor
    """φ̂_{i+1} = M_{n_i}(φ_i, â_i) ``[H, latent]``."""
    nodes: torch.Tensor
    """n_i, the node whose model predicted row i ``[H]`` (int64)."""

    @property
    def depth(self) -> int:
        """H = i − t (Alg. 1 line 8)."""
        return int(self.actions.shape[0])


@dataclass(frozen=True)
class PlanResult:
    """Outcome of `optimise_plan`: the action to execute and the plan's loss before and after."""

    action: torch.Tensor
    """First action of â^(K) (clipped to [−1, 1]) ``[action]``."""
    plan: torch.Tensor
    """The whole optimised plan ``[H, action]`` (within the bounds with ``clip="every_step"``)."""
    initial_loss: float
    final_loss: float


@torch.no_grad()
def model_rollout(
    phi: torch.Tensor,
    node: int,
    bank: ModelBank,
    actor: ActorFn,
    max_depth: int,
    continue_at: Callable[[int, int], bool],
    locate: Callable[[torch.Tensor], int],
) -> Rollout:
    """Roll μ and the local models out from φ; before step i, ``continue_at(i, n_i)`` says whether to go on.

    Step i predicts (â_i, r̂_i, φ̂_{i+1}) with node n_i's model; n_{i+1} = ``locate(φ̂_{i+1})``. Shared by
    Alg. 1 (continue while LP ≥ 0), the fixed-horizon baselines and LA-Imagination's random depth.
    """
    if max_depth < 0:
        raise ValueError(f"rollout depth limit must be >= 0, got {max_depth}")
    current = torch.as_tensor(phi, dtype=torch.float32).reshape(1, -1)
    n = int(node)
    latents, actions, rewards, next_latents, nodes = [], [], [], [], []
    for i in range(max_depth):
        if not continue_at(i, n):
            break
        action = actor(current).reshape(1, -1)
        prediction = bank.predict(torch.tensor([n]), current, action)
        latents.append(current)
        actions.append(action)
        rewards.append(prediction.reward)
        next_latents.append(prediction.next_latent)
        nodes.append(n)
        current = prediction.next_latent
        n = locate(current)
    if not nodes:
        dim = current.shape[1]
        return Rollout(
            latents=torch.zeros((0, dim)),
            actions=torch.zeros((0, bank.action_dim)),
            rewards=torch.zeros(0),
            next_latents=torch.zeros((0, dim)),
            nodes=torch.zeros(0, dtype=torch.int64),
        )
    return Rollout(
        latents=torch.cat(latents),
        actions=torch.cat(actions),
        rewards=torch.cat(rewards),
        next_latents=torch.cat(next_latents),
        nodes=torch.tensor(nodes, dtype=torch.int64),
    )


def optimise_plan(
    phi: torch.Tensor,
    rollout: Rollout,
    bank: ModelBank,
    planner: Planner,
    steps: int = 10,
    lr: float = 1e-3,
    r_star: float = 1.0,
    aim: RegionGoal | None = None,
    aim_scale: float = 0.0,
    terminal: TerminalValue | None = None,
) -> PlanResult:
    """Eq. 7: K steps on L_plan from the rollout's actions, as ``planner`` reads them (module docstring);
    with ``aim``, L_plan − ``aim_scale`` · Σ_h g(φ̃_{h+1}) (`RegionGoal.plan_term`: the planner's aim, its
    latents predicted by the start node's action map); with ``terminal``, also − γ^H V(φ̂_H) (`TerminalValue`:
    the learner's value of where the plan ends, expanded to first order where the initial plan ends)."""
    if rollout.depth == 0:
        raise ValueError("optimise_plan needs a rollout of depth >= 1 (the meta-controller chose model-free)")
    objective, step = OBJECTIVES[planner.objective], STEPS[planner.optimiser]
    project = planner.clip == "every_step"
    model = _PlanModel(bank, rollout.nodes)
    if terminal is not None:
        terminal = terminal.linearised()
    start = torch.as_tensor(phi, dtype=torch.float64).reshape(-1).numpy()
    plan = rollout.actions.detach().to(torch.float64).numpy().copy()
    if project:
        np.clip(plan, -1.0, 1.0, out=plan)
    initial_loss = None
    for _ in range(steps):
        loss, grad = model.loss_and_grad(start, plan, objective, r_star, aim, aim_scale, terminal)
        if initial_loss is None:
            initial_loss = loss
        step(plan, grad, lr)
        if project:
            np.clip(plan, -1.0, 1.0, out=plan)
    final_loss, _ = model.loss_and_grad(start, plan, objective, r_star, aim, aim_scale, terminal)
    if initial_loss is None:
        initial_loss = final_loss
    plan_t = torch.from_numpy(plan).to(torch.float32)
    return PlanResult(
        action=plan_t[0].clamp(-1.0, 1.0),
        plan=plan_t,
        initial_loss=float(initial_loss),
        final_loss=float(final_loss),
    )


def steer_plan(
    phi: torch.Tensor,
    actor: ActorFn,
    aim: RegionGoal,
    planner: Planner,
    horizon: int,
    steps: int = 10,
    lr: float = 1e-3,
) -> PlanResult:
    """The aim alone, where the local models are not trusted (`core.dual.meta_controller`): the actor's
    actions along the latents the start node's action map predicts are the initial plan ``[horizon,
    action]``, and K steps of ``planner``'s Eq. 7 step (and clip) on −Σ_h g(φ̃_{h+1}) (`RegionGoal.plan_term`)
    move it toward the goal; no predicted reward enters. The loss is reported as −Σ g."""
    if aim.action_map is None or aim.goal is None or horizon < 1:
        raise ValueError("steer_plan needs an aim with a goal and an action map, and a horizon >= 1")
    step, project = STEPS[planner.optimiser], planner.clip == "every_step"
    action_map = aim.action_map
    start = torch.as_tensor(phi, dtype=torch.float64).reshape(-1).numpy()
    latent, rows = start, []
    for _ in range(horizon):
        action = actor(torch.from_numpy(latent).to(torch.float32).reshape(1, -1))[0].double().numpy()
        rows.append(action)
        latent = action_map.carries @ latent + action_map.moves @ action + action_map.drift
    plan = np.stack(rows)
    if project:
        np.clip(plan, -1.0, 1.0, out=plan)
    losses = []
    for _ in range(steps):
        pull, d_pull = aim.plan_term(start, plan)
        losses.append(-pull)
        step(plan, -d_pull, lr)
        if project:
            np.clip(plan, -1.0, 1.0, out=plan)
    final = -aim.plan_term(start, plan)[0]
    plan_t = torch.from_numpy(plan).to(torch.float32)
    return PlanResult(action=plan_t[0].clamp(-1.0, 1.0), plan=plan_t,
                      initial_loss=float(losses[0] if losses else final), final_loss=float(final))


class _PlanModel:
    """The rollout's local models, gathered once as float64 NumPy arrays: L_plan (Eq. 6 or the per-step form)
    and its gradient w.r.t. the plan, back-propagated through time with `LocalModel`'s chain rule."""

    def __init__(self, bank: ModelBank, nodes: torch.Tensor) -> None:
        params = {k: v.double().numpy() for k, v in bank.gather(nodes).items() if k not in ("wd", "bd")}
        self.steps = [{k: v[h] for k, v in params.items()} for h in range(nodes.shape[0])]
        """Model h's parameters (the plan step's node n_h), shared layout."""
        self.model = bank.local_model.numpy()
        self.latent_dim = bank.latent_dim

    def loss_and_grad(
        self, phi: np.ndarray, plan: np.ndarray, objective: ObjectiveFn, r_star: float,
        aim: RegionGoal | None = None, aim_scale: float = 0.0, terminal: TerminalValue | None = None,
    ) -> tuple[float, np.ndarray]:
        """L_plan (minus ``aim_scale`` · the aim's pull, `RegionGoal.plan_term`, with an ``aim``; minus
        γ^H V(φ̂_H) with a ``terminal`` value) and its gradient w.r.t. the plan."""
        horizon = plan.shape[0]
        model, d = self.model, self.latent_dim
        passes = []
        rewards = np.empty(horizon)
        current = phi  # φ̂_h = M_{n_{h−1}}(φ̂_{h−1}, â_{h−1}), re-predicted from the plan
        for h in range(horizon):
            out = model.forward(self.steps[h], current, plan[h])
            passes.append(out)
            rewards[h] = out.reward
            current = out.latent
        loss, d_rewards = objective(rewards, r_star)
        grad = np.empty_like(plan)
        d_next = np.zeros(d)  # dL/dφ̂_{h+1}, flowing back from later steps
        if terminal is not None:  # − γ^H V(φ̂_H): the back-propagation starts from its gradient instead of 0
            value, d_value = terminal.value(current)
            weight = terminal.discount ** horizon
            loss -= weight * value
            d_next = -weight * np.asarray(d_value, dtype=np.float64)
        for h in reversed(range(horizon)):
            out, g_output, g_reward = passes[h], d_next, d_rewards[h]
            if model.released:  # σ′ and tanh′, in this loop's own order of products (float64 plans unchanged)
                g_output = d_next * (out.output * (1.0 - out.output))
                g_reward = g_reward * (1.0 - out.reward * out.reward)
            g_hidden = model.hidden_grad(self.steps[h], out, model.scale * g_output, g_reward)
            d_x = model.input_grad(self.steps[h], g_hidden)
            grad[h] = d_x[d:]
            through_model = d_x[:d] / model.scale  # the model reads (φ̂_h − μ) / s
            d_next = through_model + d_next if model.delta else through_model  # delta: identity path too
        if aim is not None:
            pull, d_pull = aim.plan_term(phi, plan)
            loss -= aim_scale * pull
            grad -= aim_scale * d_pull
        return float(loss), grad
