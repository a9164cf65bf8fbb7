"""Model-based control: adaptive planning depth (Algorithm 1) and gradient MPC (Eq. 6-7).

`plan_depth` rolls the actor μ and the local world models out from φ_t: at each step it checks the
learning progress of the node the current (predicted) latent falls in, stops at the first node with
LP < 0 (or no LP yet) or at D_max, and otherwise predicts (â_i, r̂_i, φ̂_{i+1}) with that node's
model. The rollout it returns is both the horizon H = i − t (Alg. 1 line 8) and the imagined
transitions (φ_i, â_i, r̂_i, φ̂_{i+1}) that I2A stores in B_latent (Alg. 3 lines 13-21).

`optimise_plan` takes the rollout's actions as the initial plan â^(0) and performs K steps of plain
gradient descent (Eq. 7) with α_plan on

- ``objective="sum"``: L_plan = (R* − Σ_h r̂_h)² (Eq. 6, paper text), or
- ``objective="per_step"``: L_plan = ½ Σ_h (R* − r̂_h)² (authors' code, with R* = 1 there),

re-predicting the latents φ̂_{h+1} = M_{n_h}(φ̂_h, â_h) through the local models at every step while
the models' weights stay fixed. Decision: the model used at plan step h is that of the node n_h the
rollout visited (Alg. 1's choice), held fixed during the K steps so the objective stays
differentiable. The gradient is back-propagated through time by hand (closed-form derivatives of
the one-hidden-layer tanh models), which costs a few dozen small matrix products instead of an
autograd graph per step; `plan_loss` is the autograd reference the tests compare it with.

Agents act in a normalised action space, [−1, 1]^d (the environment boundary rescales), so the plan's bounds
are [−1, 1]. Two readings of Eq. 7 (docs/dual-system.md, "Planner"):

- ``optimiser="sgd"``, ``clip="executed"`` (paper): plain steps of α_plan; only the executed first action
  is clipped to the bounds;
- ``optimiser="normalised"`` (the gradient scaled to length α over the whole plan) or ``"adam"`` (Adam on
  the plan, each action moves by about α per step), with α in action units, and ``clip="every_step"``:
  every action of the plan is projected onto the bounds after every step (projected gradient descent), so
  the later steps of the plan are optimised for actions that can be executed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch

from core.dual.itm import InstantaneousTopologicalMap
from core.dual.learning_progress import LearningProgress
from core.dual.model_bank import ModelBank

PlanObjective = Literal["sum", "per_step"]
PlanOptimiser = Literal["sgd", "normalised", "adam"]
PlanClip = Literal["executed", "every_step"]
ActorFn = Callable[[torch.Tensor], torch.Tensor]


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


def plan_depth(
    phi: torch.Tensor,
    node: int,
    lp: LearningProgress,
    itm: InstantaneousTopologicalMap,
    bank: ModelBank,
    actor: ActorFn,
    d_max: int,
) -> Rollout:
    """Algorithm 1 (with Alg. 3 lines 13-21): roll out while LP_{i,n} ≥ 0 and i < D_max."""
    if d_max < 0:
        raise ValueError(f"d_max must be >= 0, got {d_max}")
    return model_rollout(
        phi, node, bank, actor, d_max,
        continue_at=lambda _i, n: bool(lp.reliable(n)[0]),
        locate=lambda latent: int(itm.nearest(latent)[0]),
    )


def plan_loss(
    phi: torch.Tensor,
    plan: torch.Tensor,
    nodes: torch.Tensor,
    bank: ModelBank,
    objective: PlanObjective = "sum",
    r_star: float = 1.0,
) -> torch.Tensor:
    """L_plan (Eq. 6 or the released per-step form), differentiable in ``plan`` (autograd reference)."""
    params = bank.gather(nodes)
    current = torch.as_tensor(phi, dtype=torch.float32).reshape(1, -1)
    rewards = []
    for h in range(plan.shape[0]):
        step = {k: v[h : h + 1] for k, v in params.items()}
        current, reward = bank.forward_with(step, current, plan[h : h + 1])
        rewards.append(reward)
    r = torch.cat(rewards)
    if objective == "sum":
        return (r_star - r.sum()) ** 2
    return 0.5 * ((r_star - r) ** 2).sum()


def optimise_plan(
    phi: torch.Tensor,
    rollout: Rollout,
    bank: ModelBank,
    steps: int = 10,
    lr: float = 1e-3,
    objective: PlanObjective = "sum",
    r_star: float = 1.0,
    optimiser: PlanOptimiser = "sgd",
    clip: PlanClip = "executed",
) -> PlanResult:
    """Eq. 7: K steps on L_plan from the rollout's actions (plain, normalised or Adam; module docstring)."""
    if objective not in ("sum", "per_step"):
        raise ValueError(f"plan objective must be 'sum' or 'per_step', got {objective!r}")
    if optimiser not in ("sgd", "normalised", "adam"):
        raise ValueError(f"plan optimiser must be 'sgd', 'normalised' or 'adam', got {optimiser!r}")
    if clip not in ("executed", "every_step"):
        raise ValueError(f"plan clip must be 'executed' or 'every_step', got {clip!r}")
    if rollout.depth == 0:
        raise ValueError("optimise_plan needs a rollout of depth >= 1 (the meta-controller chose model-free)")
    model = _PlanModel(bank, rollout.nodes)
    start = torch.as_tensor(phi, dtype=torch.float64).reshape(-1).numpy()
    plan = rollout.actions.detach().to(torch.float64).numpy().copy()
    if clip == "every_step":
        np.clip(plan, -1.0, 1.0, out=plan)
    first = np.zeros_like(plan)
    second = np.zeros_like(plan)
    initial_loss = None
    for k in range(1, steps + 1):
        loss, grad = model.loss_and_grad(start, plan, objective, r_star)
        if initial_loss is None:
            initial_loss = loss
        if optimiser == "sgd":
            plan -= lr * grad
        elif optimiser == "normalised":
            norm = float(np.sqrt((grad * grad).sum()))
            if norm > 0.0:
                plan -= lr * grad / norm
        else:  # Adam on the plan (β = 0.9, 0.999), bias-corrected
            first = 0.9 * first + 0.1 * grad
            second = 0.999 * second + 0.001 * grad * grad
            plan -= lr * (first / (1.0 - 0.9**k)) / (np.sqrt(second / (1.0 - 0.999**k)) + 1e-8)
        if clip == "every_step":
            np.clip(plan, -1.0, 1.0, out=plan)
    final_loss, _ = model.loss_and_grad(start, plan, objective, r_star)
    if initial_loss is None:
        initial_loss = final_loss
    plan_t = torch.from_numpy(plan).to(torch.float32)
    return PlanResult(
        action=plan_t[0].clamp(-1.0, 1.0),
        plan=plan_t,
        initial_loss=float(initial_loss),
        final_loss=float(final_loss),
    )


class _PlanModel:
    """The rollout's local models, gathered once as float64 NumPy arrays, with a hand-written BPTT."""

    def __init__(self, bank: ModelBank, nodes: torch.Tensor) -> None:
        p = bank.gather(nodes)
        self.w1 = p["w1"].double().numpy()  # [H, in, hidden]
        self.b1 = p["b1"].double().numpy()
        self.wm = p["wm"].double().numpy()  # [H, hidden, latent]
        self.bm = p["bm"].double().numpy()
        self.wr = p["wr"].double().numpy()[..., 0]  # [H, hidden]
        self.br = p["br"].double().numpy()[:, 0]
        self.latent_dim = bank.latent_dim
        self.released = bank.output_activation == "released"
        self.delta = bank.target == "delta"
        self.scale = float(bank.latent_scale)
        self.offset = bank.latent_offset.double().numpy()

    def loss_and_grad(
        self, phi: np.ndarray, plan: np.ndarray, objective: PlanObjective, r_star: float
    ) -> tuple[float, np.ndarray]:
        horizon = plan.shape[0]
        d = self.latent_dim
        hiddens, latent_grads_act, reward_grads_act, inputs = [], [], [], []
        rewards = np.empty(horizon)
        current = phi
        s, offset = self.scale, self.offset
        for h in range(horizon):
            x = np.concatenate([(current - offset) / s, plan[h]])
            hidden = np.tanh(x @ self.w1[h] + self.b1[h])
            pre_latent = hidden @ self.wm[h] + self.bm[h]
            pre_reward = hidden @ self.wr[h] + self.br[h]
            if self.released:
                nxt = 1.0 / (1.0 + np.exp(-pre_latent))
                reward = np.tanh(pre_reward)
                latent_grads_act.append(nxt * (1.0 - nxt))
                reward_grads_act.append(1.0 - reward * reward)
            else:
                nxt, reward = pre_latent, pre_reward
                latent_grads_act.append(None)
                reward_grads_act.append(1.0)
            nxt = s * nxt + (current if self.delta else offset)
            inputs.append(x)
            hiddens.append(hidden)
            rewards[h] = reward
            current = nxt
        if objective == "sum":
            residual = r_star - rewards.sum()
            loss = residual * residual
            d_rewards = np.full(horizon, -2.0 * residual)
        else:
            residual = r_star - rewards
            loss = 0.5 * float(residual @ residual)
            d_rewards = -residual
        grad = np.empty_like(plan)
        d_next = np.zeros(d)  # dL/dφ̂_{h+1}, flowing back from later steps
        for h in reversed(range(horizon)):
            d_pre_latent = d_next if latent_grads_act[h] is None else d_next * latent_grads_act[h]
            d_pre_reward = d_rewards[h] * reward_grads_act[h]
            d_hidden = self.wm[h] @ (s * d_pre_latent) + self.wr[h] * d_pre_reward
            d_z = d_hidden * (1.0 - hiddens[h] ** 2)
            d_x = self.w1[h] @ d_z
            grad[h] = d_x[d:]
            through_model = d_x[:d] / s  # the model reads (φ̂_h − μ) / s
            d_next = through_model + d_next if self.delta else through_model  # delta: identity path too
        return float(loss), grad
