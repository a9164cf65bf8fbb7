"""Algorithm 1 (adaptive planning depth, through the meta-controller's live path) and Eq. 6-7 (gradient MPC
over the local models, as each planner reading reads them)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch
from torch import nn

from core.config import load_config
from core.dual.itm import InstantaneousTopologicalMap
from core.dual.learning_progress import LearningProgress
from core.dual.meta_controller import MetaController
from core.dual.model_bank import ModelBank
from core.dual.planning import Rollout, optimise_plan
from core.dual.readings import PLANNER, Planner, resolve
from core.dual.world_models import LocalWorldModels

PAPER = PLANNER["paper"]
RELEASED = PLANNER["released"]
REPAIRED = PLANNER["repaired"]
SUM_NORMALISED = Planner(objective="sum", optimiser="normalised", clip="executed")
SUM_PROJECTED = Planner(objective="sum", optimiser="sgd", clip="every_step")


def _chain(n_nodes: int, reliable: list[bool]):
    """Nodes at (10k, 0); node k's model predicts exactly node k+1's position and reward 0.1·k."""
    itm = InstantaneousTopologicalMap(dim=2, e_max=1.0, initial_weights=np.array([[0.0, 0.0], [10.0, 0.0]]))
    for k in range(2, n_nodes):
        assert itm.update(np.array([10.0 * k, 0.0])).added == (k,)
    bank = ModelBank(latent_dim=2, action_dim=1, hidden=3, initial_capacity=n_nodes)
    for name in ("w1", "b1", "wm", "wr"):
        bank.params[name].zero_()
    bank.params["bm"][:n_nodes] = torch.tensor([[10.0 * (k + 1), 0.0] for k in range(n_nodes)])
    bank.params["br"][:n_nodes, 0] = torch.tensor([0.1 * k for k in range(n_nodes)])
    lp = LearningProgress(window=1, history=1)
    for k, ok in enumerate(reliable):
        lp.record([k, k], [2.0, 1.0] if ok else [1.0, 2.0])  # LP = +1 or −1
    return itm, bank, lp


def _actor() -> nn.Module:
    torch.manual_seed(0)
    return nn.Sequential(nn.Linear(2, 1), nn.Tanh())


def _rollout(n_nodes: int, reliable: list[bool], d_max: int) -> Rollout:
    """Alg. 1's rollout as the meta-controller makes it (`MetaController.rollout`), over the chain's map,
    models and LP (the paper profile's LP reliability)."""
    dual = load_config("paper", [f"dual.d_max={d_max}"]).dual
    world = LocalWorldModels(dual, 2, 1, readings=resolve(dual))
    world.itm, world.bank, world.lp = _chain(n_nodes, reliable)
    return MetaController(world, dual).rollout(torch.zeros(1, 2), 0, _actor())


def test_depth_stops_at_first_negative_lp_node() -> None:
    rollout = _rollout(6, [True, True, False, True, True, True], d_max=6)
    assert rollout.depth == 2
    assert rollout.nodes.tolist() == [0, 1]
    torch.testing.assert_close(rollout.next_latents, torch.tensor([[10.0, 0.0], [20.0, 0.0]]))
    # Each row is an imagined transition (φ_i, â_i, r̂_i, φ̂_{i+1}) and the rows chain.
    torch.testing.assert_close(rollout.latents[1], rollout.next_latents[0])
    torch.testing.assert_close(rollout.rewards, torch.tensor([0.0, 0.1]))
    torch.testing.assert_close(rollout.actions, _actor()(rollout.latents).detach())


def test_depth_stops_at_d_max() -> None:
    assert _rollout(8, [True] * 8, d_max=3).depth == 3
    assert _rollout(8, [True] * 8, d_max=6).depth == 6


def test_depth_zero_when_start_node_unreliable_or_without_history() -> None:
    assert _rollout(4, [False, True, True, True], d_max=6).depth == 0
    assert _rollout(4, [], d_max=6).depth == 0


def plan_loss(phi: torch.Tensor, plan: torch.Tensor, nodes: torch.Tensor, bank: ModelBank,
              objective: str = "sum", r_star: float = 1.0) -> torch.Tensor:
    """The autograd reference: L_plan (Eq. 6 or the per-step form) through the bank's `LocalModel.forward`."""
    params = bank.gather(nodes)
    current = torch.as_tensor(phi, dtype=torch.float32).reshape(1, -1)
    rewards = []
    for h in range(plan.shape[0]):
        out = bank.local_model.forward({k: v[h : h + 1] for k, v in params.items()}, current, plan[h : h + 1])
        current = out.latent
        rewards.append(out.reward)
    r = torch.cat(rewards)
    if objective == "sum":
        return (r_star - r.sum()) ** 2
    return 0.5 * ((r_star - r) ** 2).sum()


def _random_setup(activation: str = "linear"):
    bank = ModelBank(latent_dim=4, action_dim=1, hidden=20, output_activation=activation,
                     generator=torch.Generator().manual_seed(7), initial_capacity=8)
    nodes = torch.tensor([2, 5, 5, 1])
    g = torch.Generator().manual_seed(1)
    phi = torch.rand(4, generator=g)
    plan = torch.rand(4, 1, generator=g) * 2 - 1
    return bank, nodes, phi, plan


@pytest.mark.parametrize("planner", [PAPER, RELEASED])
@pytest.mark.parametrize("activation", ["linear", "released"])
def test_mpc_steps_lower_the_plan_loss_with_models_fixed(planner: Planner, activation: str) -> None:
    objective = planner.objective
    bank, nodes, phi, plan = _random_setup(activation)
    before = {k: v.clone() for k, v in bank.params.items()}
    rollout = Rollout(latents=phi[None].repeat(4, 1), actions=plan, rewards=torch.zeros(4),
                      next_latents=phi[None].repeat(4, 1), nodes=nodes)
    losses = []
    for k in range(0, 11, 2):
        result = optimise_plan(phi, rollout, bank, planner, steps=k, lr=0.05, r_star=1.0)
        losses.append(result.final_loss)
    assert all(b < a for a, b in itertools.pairwise(losses)), losses
    # The paper's α_plan = 1e-3 and K = 10 also lower the loss (a little).
    small = optimise_plan(phi, rollout, bank, planner, steps=10, lr=1e-3)
    assert small.final_loss < small.initial_loss
    ref = plan_loss(phi, small.plan, nodes, bank, objective)
    assert float(ref) == pytest.approx(small.final_loss, rel=1e-5)
    for k, v in before.items():
        assert torch.equal(bank.params[k], v)
    assert -1.0 <= float(small.action[0]) <= 1.0


@pytest.mark.parametrize("planner", [PAPER, RELEASED])
@pytest.mark.parametrize("activation", ["linear", "released"])
def test_hand_written_gradient_equals_autograd(planner: Planner, activation: str) -> None:
    objective = planner.objective
    bank, nodes, phi, plan = _random_setup(activation)
    a = plan.clone().requires_grad_(True)
    loss = plan_loss(phi, a, nodes, bank, objective, r_star=0.7)
    (grad,) = torch.autograd.grad(loss, a)
    rollout = Rollout(latents=phi[None].repeat(4, 1), actions=plan, rewards=torch.zeros(4),
                      next_latents=phi[None].repeat(4, 1), nodes=nodes)
    one = optimise_plan(phi, rollout, bank, planner, steps=1, lr=1.0, r_star=0.7)
    torch.testing.assert_close(plan - one.plan, grad, atol=1e-5, rtol=1e-4)
    assert one.initial_loss == pytest.approx(float(loss.detach()), rel=1e-5)


def test_optimise_plan_rejects_an_empty_rollout() -> None:
    empty = _rollout(3, [False], d_max=6)
    _, bank, _ = _chain(3, [False])
    with pytest.raises(ValueError, match="depth"):
        optimise_plan(torch.zeros(2), empty, bank, PAPER)


def test_normalised_steps_lower_the_loss_by_action_sized_steps() -> None:
    bank, nodes, phi, plan = _random_setup()
    rollout = Rollout(latents=phi[None].repeat(4, 1), actions=plan * 0.5, rewards=torch.zeros(4),
                      next_latents=phi[None].repeat(4, 1), nodes=nodes)
    sgd = optimise_plan(phi, rollout, bank, PAPER, steps=10, lr=1e-3)
    result = optimise_plan(phi, rollout, bank, REPAIRED, steps=10, lr=0.05)
    assert result.final_loss < result.initial_loss
    moved = float((result.plan - rollout.actions).abs().max())
    assert 0.05 <= moved <= 0.6  # about α per step, about K·α at most; plain SGD at the paper's α: ~0
    assert float((sgd.plan - rollout.actions).abs().max()) < 0.01
    unprojected = optimise_plan(phi, rollout, bank, SUM_NORMALISED, steps=10, lr=0.05)
    assert unprojected.final_loss < unprojected.initial_loss


def test_every_step_clip_keeps_every_plan_action_in_bounds() -> None:
    bank, nodes, phi, plan = _random_setup()
    rollout = Rollout(latents=phi[None].repeat(4, 1), actions=plan, rewards=torch.zeros(4),
                      next_latents=phi[None].repeat(4, 1), nodes=nodes)
    literal = optimise_plan(phi, rollout, bank, PAPER, steps=10, lr=50.0)
    assert float(literal.plan.abs().max()) > 1.0  # Eq. 7 as printed: only the executed action is clipped
    assert float(literal.action.abs().max()) <= 1.0
    projected = optimise_plan(phi, rollout, bank, SUM_PROJECTED, steps=10, lr=50.0)
    assert float(projected.plan.abs().max()) <= 1.0
    ref = plan_loss(phi, projected.plan, nodes, bank)
    assert float(ref) == pytest.approx(projected.final_loss, rel=1e-5)


def test_hand_written_gradient_equals_autograd_for_a_delta_model_in_normalised_units() -> None:
    bank = ModelBank(latent_dim=4, action_dim=1, hidden=20, target="delta", termination=True,
                     generator=torch.Generator().manual_seed(7), initial_capacity=8)
    bank.params["wr"].normal_(0.0, 0.3)  # a delta model's reward head starts at 0: give it a slope
    bank.latent_scale, bank.latent_offset = 0.2, torch.tensor([0.5, -0.5, 0.1, 0.0])
    _, nodes, phi, plan = _random_setup()
    a = plan.clone().requires_grad_(True)
    (grad,) = torch.autograd.grad(plan_loss(phi, a, nodes, bank, "sum", r_star=0.7), a)
    rollout = Rollout(latents=phi[None].repeat(4, 1), actions=plan, rewards=torch.zeros(4),
                      next_latents=phi[None].repeat(4, 1), nodes=nodes)
    one = optimise_plan(phi, rollout, bank, PAPER, steps=1, lr=1.0, r_star=0.7)
    torch.testing.assert_close(plan - one.plan, grad, atol=1e-5, rtol=1e-4)


def _assert_exact_gradient(value, grad: np.ndarray, x: np.ndarray) -> None:
    """``grad[row, dim]`` against central finite differences of ``value(x, row)`` (the scalar whose gradient
    it is: row ``row``'s pull for a goal's per-latent gradient, the plan's total pull for a plan's)."""
    eps = 1e-6
    for row, dim in np.ndindex(*x.shape):
        up, down = x.copy(), x.copy()
        up[row, dim] += eps
        down[row, dim] -= eps
        numeric = (value(up, row) - value(down, row)) / (2 * eps)
        assert grad[row, dim] == pytest.approx(numeric, rel=1e-5, abs=1e-8)


def test_region_goal_is_where_the_capped_neighbour_average_peaks_and_its_pull_is_exact() -> None:
    """`RegionGoal`: s = each value averaged with its map neighbours' and capped at its own, the goal the node
    where s peaks, the pull's length the peak's contrast max s − mean s; a single spike among low neighbours
    loses to a plateau of high ones (the noise third's fluctuating nodes against a region being learnt); a
    node of value 0 beside a high one does not put the goal on itself; exact gradient."""
    from core.dual.region_goal import RegionGoal

    # a chain 0-1-2 (a plateau being learnt) and a chain 3-4 (a spike at 4 beside a learnt node 3)
    centres = np.array([[0.0, 0.0], [2.0, 0.0], [4.0, 0.0], [0.0, 6.0], [0.0, 8.0]])
    values = np.array([0.6, 0.7, 0.6, 0.0, 1.0])
    adjacency = np.zeros((5, 5), dtype=bool)
    for a, b in ((0, 1), (1, 2), (3, 4)):
        adjacency[a, b] = adjacency[b, a] = True
    goal = RegionGoal(centres, values, unit=2.0, adjacency=adjacency)
    smoothed = [0.6, 1.9 / 3, 0.6, 0.0, 0.5]  # averages 0.65, 0.633, 0.65, 0.5, 0.5, each capped at its value
    np.testing.assert_allclose(goal.smoothed, smoothed)
    np.testing.assert_allclose(goal.goal, centres[1])  # the plateau's middle, not the spike
    assert goal.weight == pytest.approx(1.9 / 3 - np.mean(smoothed))
    spike = RegionGoal(centres, values, unit=2.0)  # without the map's edges the spike is the peak
    np.testing.assert_allclose(spike.goal, [0.0, 8.0])
    assert spike.weight == pytest.approx(1.0 - values.mean())
    # a star: node 0 (value 1) linked to three nodes of value 0; uncapped, each leaf's average (0 + 1) / 2
    # beat the hub's 1 / 4 and the goal sat on a leaf of value 0; capped, the leaves score 0
    star = np.zeros((4, 4), dtype=bool)
    star[0, 1:] = star[1:, 0] = True
    hub = RegionGoal(centres[:4], np.array([1.0, 0.0, 0.0, 0.0]), adjacency=star)
    np.testing.assert_allclose(hub.smoothed, [0.25, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(hub.goal, centres[0])
    tied = RegionGoal(centres[:2], np.array([0.5, 0.5]), adjacency=np.zeros((2, 2)))
    assert tied.goal is None  # equal values: no contrast, no aim
    far_goal = RegionGoal(centres[[0, 2, 3]], np.array([0.4, 0.4, 0.0]))
    np.testing.assert_allclose(far_goal.goal, [2.0, 0.0])  # tied peaks: their mean
    far, _ = goal(np.array([[2.0 + 6.0, 0.0]]) * 2.0)  # u = 6 map units beyond the goal
    assert far[0] == pytest.approx(-goal.weight * 6.0, rel=1e-6)  # − w · distance
    flat, flat_grad = RegionGoal(centres, np.full(5, 0.3), adjacency=adjacency)(centres)  # nothing stands out
    assert not flat.any() and not flat_grad.any()
    latents = np.array([[1.0, 0.4], [0.3, 1.5], [2.2, -0.7]])
    _assert_exact_gradient(lambda x, row: goal(x)[0][row], goal(latents)[1], latents)
    none, none_grad = RegionGoal(centres, np.zeros(5), adjacency=adjacency)(latents)  # no value: no aim
    assert not none.any() and not none_grad.any()
    with pytest.raises(ValueError, match="adjacency"):
        RegionGoal(centres, values, adjacency=adjacency[:4, :4])


def test_a_plans_pull_is_predicted_by_the_action_map_with_an_exact_gradient() -> None:
    """`RegionGoal.plan_term`: the pull summed over φ̃_{h+1} = φ + Σ_{i≤h} B â_i (no coupling, no drift), its
    gradient w.r.t. the plan against finite differences; a plan along B toward the goal scores higher; no
    action map: no pull."""
    from core.dual.action_map import ActionMap
    from core.dual.region_goal import RegionGoal

    centres = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 1.0]])
    moves = np.array([[0.5, 0.0], [0.0, 0.5], [0.0, 0.0]])  # actions move the first two directions
    goal = RegionGoal(centres, np.array([0.0, 1.0]), action_map=ActionMap(moves, np.eye(3), np.zeros(3)))
    phi = np.array([0.0, 0.0, -3.0])
    toward, away = np.tile([1.0, 0.0], (3, 1)), np.tile([-1.0, 0.0], (3, 1))
    # toward: φ̃ = (0.5, 0, −3), (1, 0, −3), (1.5, 0, −3): distances to ḡ = (2, 0, 1) are √(1.5² + 16) …
    expected = -0.5 * sum(np.sqrt((2.0 - x) ** 2 + 16.0 + 1e-6) for x in (0.5, 1.0, 1.5))
    assert goal.plan_term(phi, toward)[0] == pytest.approx(expected)
    assert goal.plan_term(phi, toward)[0] > goal.plan_term(phi, away)[0]
    plan = np.array([[0.3, -0.2], [0.9, 0.4], [-0.5, 0.1]])
    _assert_exact_gradient(lambda x, _: goal.plan_term(phi, x)[0], goal.plan_term(phi, plan)[1], plan)
    unmapped = RegionGoal(centres, np.array([0.0, 1.0]))
    value, unmapped_grad = unmapped.plan_term(phi, plan)
    assert value == 0.0 and not unmapped_grad.any()


def _world_with_transitions(screen: str, steps: int = 200):
    """A world of one node fed ``steps`` transitions: actions move the first two latent directions by
    0.05·a; the third is a screen that ``screen`` = ``jumps`` (now and then at random), ``shows`` (a new
    value each step set by the action, as the check's learnable third) or ``keeps`` (unchanged)."""
    from core.config import load_config
    from core.dual.readings import resolve
    from core.dual.world_models import LocalWorldModels

    dual = load_config("default").dual
    world = LocalWorldModels(dual, 3, 2, generator=torch.Generator().manual_seed(0), readings=resolve(dual))
    rng = np.random.default_rng(0)
    phi = torch.zeros(3)
    node = world.observe_state(phi)
    assert world.action_map(node) is None  # nothing stored yet
    for step in range(steps):
        action = rng.uniform(-1.0, 1.0, size=2)
        start = torch.tensor([rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01), rng.uniform(-1.0, 1.0)])
        start = start.to(torch.float32)
        screen_value = {"jumps": float(start[2]) + (rng.uniform(-1.0, 1.0) if step % 10 == 0 else 0.0),
                        "shows": float(np.sin(2.0 * action[0])), "keeps": float(start[2])}[screen]
        nxt = torch.tensor([start[0] + 0.05 * action[0], start[1] + 0.05 * action[1], screen_value],
                           dtype=torch.float32)
        world.learn_transition(node, start, torch.tensor(action, dtype=torch.float32), 0.0, nxt)
    return world, node


@pytest.mark.parametrize("screen", ["jumps", "shows", "keeps"])
def test_the_action_map_keeps_the_directions_actions_move_and_the_latent_carries(screen: str) -> None:
    """`LocalWorldModels.action_map`: actions move a position (carried from step to step) and, with
    ``shows``, a screen whose next value the action sets whatever it showed before (moved, not carried);
    B is the position's 0.05·I and nothing along the screen, however the screen changes."""
    world, node = _world_with_transitions(screen)
    action_map = world.action_map(node)
    assert action_map is not None
    np.testing.assert_allclose(action_map.moves, [[0.05, 0.0], [0.0, 0.05], [0.0, 0.0]], atol=5e-3)


def test_the_action_map_carries_a_coupling_so_a_goal_reached_through_it_pulls() -> None:
    """`fit_action_map` on MountainCar-like dynamics (the action moves a velocity, the velocity the position,
    v′ = v + 0.1·a, x′ = x + v′): M = I + QD holds the coupling, and a plan that pushes toward a goal at a
    position scores above standing still — under B alone (no coupling) it scored below, since pushing only
    moves the velocity away from the goal's. The rollout is the fitted dynamics; the gradient is exact."""
    from core.dual.action_map import ActionMap, fit_action_map
    from core.dual.region_goal import RegionGoal

    rng = np.random.default_rng(0)
    states = np.c_[rng.uniform(-0.5, 0.5, 200), rng.uniform(-0.1, 0.1, 200)]
    actions = rng.uniform(-1.0, 1.0, (200, 1))
    velocity = states[:, 1] + 0.1 * actions[:, 0]
    nxt = np.c_[states[:, 0] + velocity, velocity]
    fitted = fit_action_map(*(torch.tensor(x, dtype=torch.float32) for x in (states, actions, nxt)))
    assert fitted is not None
    np.testing.assert_allclose(fitted.moves, [[0.1], [0.1]], atol=1e-5)
    np.testing.assert_allclose(fitted.carries, [[1.0, 1.0], [0.0, 1.0]], atol=1e-5)
    np.testing.assert_allclose(fitted.drift, [0.0, 0.0], atol=1e-5)
    plan, still = np.ones((5, 1)), np.zeros((5, 1))
    expected, latent = [], np.zeros(2)
    for _ in range(5):
        latent = np.array([latent[0] + latent[1] + 0.1, latent[1] + 0.1])
        expected.append(latent)
    np.testing.assert_allclose(fitted.rollout(np.zeros(2), plan), expected, atol=1e-5)
    centres, values = np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.0, 1.0])  # the goal: x = 1 at rest
    coupled = RegionGoal(centres, values, action_map=fitted)
    assert coupled.plan_term(np.zeros(2), plan)[0] > coupled.plan_term(np.zeros(2), still)[0]
    moves_only = RegionGoal(centres, values, action_map=ActionMap(fitted.moves * [[0.0], [1.0]], np.eye(2),
                                                                  np.zeros(2)))
    assert moves_only.plan_term(np.zeros(2), plan)[0] < moves_only.plan_term(np.zeros(2), still)[0]
    mixed = rng.uniform(-1.0, 1.0, (5, 1))
    _assert_exact_gradient(lambda x, _: coupled.plan_term(np.zeros(2), x)[0],
                           coupled.plan_term(np.zeros(2), mixed)[1], mixed)


def test_an_aimed_plan_gradient_is_exact_and_steps_toward_the_aim() -> None:
    """The plan's gradient, the return's back-propagated through the models by hand plus the aim's through the
    action map, against finite differences; with no reward to follow, the plan moves toward the goal."""
    from core.dual.action_map import ActionMap
    from core.dual.planning import OBJECTIVES, _PlanModel
    from core.dual.region_goal import RegionGoal

    bank, nodes, phi, plan = _random_setup()
    model = _PlanModel(bank, nodes)
    start = phi.double().numpy()
    actions = plan.double().numpy()
    coupled = ActionMap(moves=np.array([[0.3], [-0.2], [0.1], [0.4]]),
                        carries=np.eye(4) + 0.1 * np.eye(4, k=1), drift=np.array([0.01, 0.0, -0.02, 0.0]))
    field = RegionGoal(np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]]), np.array([0.0, 1.0]),
                       action_map=coupled)
    _, grad = model.loss_and_grad(start, actions, OBJECTIVES["return"], 1.0, field, 0.7)
    eps = 1e-6
    for h in range(actions.shape[0]):
        up, down = actions.copy(), actions.copy()
        up[h, 0] += eps
        down[h, 0] -= eps
        numeric = (model.loss_and_grad(start, up, OBJECTIVES["return"], 1.0, field, 0.7)[0]
                   - model.loss_and_grad(start, down, OBJECTIVES["return"], 1.0, field, 0.7)[0]) / (2 * eps)
        assert grad[h, 0] == pytest.approx(numeric, rel=1e-4, abs=1e-7)
    rollout = Rollout(latents=phi[None].repeat(4, 1), actions=plan, rewards=torch.zeros(4),
                      next_latents=phi[None].repeat(4, 1), nodes=nodes)
    aimed = optimise_plan(phi, rollout, bank, PLANNER["progress"], steps=10, lr=0.05, aim=field,
                          aim_scale=1.0)
    assert aimed.final_loss < aimed.initial_loss


def test_a_steered_plan_starts_at_the_actors_actions_and_moves_toward_the_goal_alone() -> None:
    """`steer_plan`: the initial plan is the actor's actions along the latents the action map predicts; K
    steps on −Σ g move the plan toward the goal (its loss, −Σ g, falls; the first action points along B
    toward the goal); every action stays in [−1, 1]; no goal or no action map is refused."""
    from core.dual.action_map import ActionMap
    from core.dual.planning import steer_plan
    from core.dual.region_goal import RegionGoal

    moves = np.array([[0.5, 0.0], [0.0, 0.5], [0.0, 0.0]])
    centres = np.array([[0.0, 0.0, 0.0], [3.0, -2.0, 0.0]])
    goal = RegionGoal(centres, np.array([0.0, 1.0]), action_map=ActionMap(moves, np.eye(3), np.zeros(3)))
    calls = []

    def actor(phi: torch.Tensor) -> torch.Tensor:
        calls.append(phi.clone())
        return torch.zeros(1, 2)

    phi = torch.zeros(1, 3)
    zero = steer_plan(phi, actor, goal, PLANNER["progress"], horizon=4, steps=0)
    assert len(calls) == 4 and not zero.plan.any()  # the actor's actions along the predicted latents
    assert zero.final_loss == pytest.approx(-goal.plan_term(np.zeros(3), np.zeros((4, 2)))[0])
    steered = steer_plan(phi, actor, goal, PLANNER["progress"], horizon=4, steps=20, lr=0.05)
    assert steered.final_loss < steered.initial_loss
    assert steered.action[0] > 0.0 > steered.action[1]  # toward the goal's (+x, −y)
    assert steered.plan.abs().max() <= 1.0
    for aim in (RegionGoal(centres, np.array([0.0, 1.0])), RegionGoal(centres, np.zeros(2))):
        with pytest.raises(ValueError, match="goal and an action map"):
            steer_plan(phi, actor, aim, PLANNER["progress"], horizon=4)


def test_an_aiming_planner_steers_where_the_models_are_not_trusted_and_other_planners_do_not() -> None:
    """`MetaController.decide`: at a node that is not reliable, an aiming planner with a goal and an action
    map steers (model-based, no rollout: nothing to imagine); the ``repaired`` planner acts model-free
    there."""
    from core.config import load_config
    from core.dual.meta_controller import MetaController
    from core.dual.readings import resolve
    from core.dual.world_models import LocalWorldModels

    class Untrusted(LocalWorldModels):
        def reliable(self, node: int) -> bool:
            return False

        def aim_values(self, aim: str, regions: np.ndarray) -> np.ndarray:
            return (self.itm.weights(regions)[:, 0] > 0.0).astype(np.float64)  # the right half

    actor = lambda phi: torch.zeros(phi.shape[0], 2)  # noqa: E731
    rng = np.random.default_rng(0)
    decisions = {}
    for planner in ("progress", "repaired"):
        dual = load_config("default", [f"dual.planner={planner}"]).dual
        world = Untrusted(dual, 3, 2, generator=torch.Generator().manual_seed(0), readings=resolve(dual))
        for _ in range(300):
            phi = torch.tensor([*rng.uniform(-1.0, 1.0, size=2), 0.0], dtype=torch.float32)
            action = rng.uniform(-1.0, 1.0, size=2)
            node = world.observe_state(phi)
            nxt = phi + torch.tensor([0.05 * action[0], 0.05 * action[1], 0.0], dtype=torch.float32)
            world.learn_transition(node, phi, torch.tensor(action, dtype=torch.float32), 0.0, nxt)
        start = torch.tensor([-0.9, 0.0, 0.0])
        decisions[planner] = MetaController(world, dual).decide(start, world.observe_state(start), actor)
    steered, plain = decisions["progress"], decisions["repaired"]
    assert steered.model_based and steered.steered and steered.rollout is None
    assert steered.action[0] > 0.0  # toward the right half
    assert not plain.model_based and not plain.steered and not plain.action.any()


def test_the_plan_bench_times_both_readings_on_a_node_with_an_action_map() -> None:
    """`dualsys bench plan`'s contract: both readings timed on the same rollout, the aim's node fitted."""
    from bench.plan_speed import measure

    result = measure(latent_dim=3, action_dim=2, repeats=2)
    assert set(result["ms_per_decision"]) == {"no_aim", "aim"}
    assert result["horizon"] >= 1 and result["stored_transitions"] >= 4 * (2 + 3 + 1)
    assert result["ratio_aim_to_no_aim"] > 0.0


def test_a_terminal_value_enters_the_plan_objective_with_its_exact_gradient() -> None:
    """Item 23: with a `TerminalValue` the plan's loss falls by γ^H V(φ̂_H), φ̂_H the latent the plan's models
    predict at its end, and the hand-written back-propagation (started from ∇V instead of 0) matches finite
    differences; a planner reading refuses a terminal value without the return objective."""
    from core.dual.planning import OBJECTIVES, TerminalValue, _PlanModel

    bank, nodes, phi, plan = _random_setup()
    model = _PlanModel(bank, nodes)
    start, actions = phi.double().numpy(), plan.double().numpy()
    target = np.array([0.5, -0.2, 0.1, 0.3])

    def value(latent: np.ndarray) -> tuple[float, np.ndarray]:
        return float(-((latent - target) ** 2).sum()), -2.0 * (latent - target)

    terminal = TerminalValue(value, discount=0.9)
    bare, bare_grad = model.loss_and_grad(start, actions, OBJECTIVES["return"], 1.0)
    loss, grad = model.loss_and_grad(start, actions, OBJECTIVES["return"], 1.0, terminal=terminal)
    end = start
    for h in range(actions.shape[0]):
        end = bank.local_model.numpy().forward(model.steps[h], end, actions[h]).latent
    assert loss == pytest.approx(bare - 0.9 ** actions.shape[0] * value(end)[0], rel=1e-12)
    assert not np.allclose(grad, bare_grad)
    eps = 1e-6
    for h in range(actions.shape[0]):
        up, down = actions.copy(), actions.copy()
        up[h, 0] += eps
        down[h, 0] -= eps
        numeric = (model.loss_and_grad(start, up, OBJECTIVES["return"], 1.0, terminal=terminal)[0]
                   - model.loss_and_grad(start, down, OBJECTIVES["return"], 1.0, terminal=terminal)[0])
        numeric /= 2 * eps
        assert grad[h, 0] == pytest.approx(numeric, rel=1e-4, abs=1e-7)
    with pytest.raises(ValueError, match="return"):
        Planner(objective="sum", optimiser="normalised", clip="every_step", terminal=True)
    aiming = ("progress", "novelty", "disagreement", "babbling", "value")
    assert all(PLANNER[name].terminal for name in aiming)
    assert not any(PLANNER[name].terminal for name in ("paper", "released", "repaired"))
    assert PLANNER["value"].aim == "none"


def test_the_learners_value_gradient_is_exact_and_leaves_the_weights_alone() -> None:
    """`Learner.value_and_gradient`: V(φ) = min_i Q_i(φ, μ(φ)) equals `value_of`, its gradient w.r.t. φ
    (through the critic and μ) matches finite differences in float64, and no parameter gets a ``.grad``."""
    from core.envs.spec import EnvSpec
    from core.modelfree.learners import make_learner

    torch.manual_seed(0)
    config = load_config("vector", ["net.mlp_hidden=16,16", "agent.ac=sac"])
    spec = EnvSpec(obs_shape=(3,), action_dim=2, obs_kind="vector", obs_dtype="float32")
    learner = make_learner(config.net, config.agent, spec).double()
    phi = torch.randn(2, learner.latent_dim, dtype=torch.float64)
    value, grad = learner.value_and_gradient(phi)
    torch.testing.assert_close(value, learner.value_of(phi))
    eps = 1e-6
    for i in range(learner.latent_dim):
        step = torch.zeros_like(phi)
        step[:, i] = eps
        numeric = (learner.value_of(phi + step) - learner.value_of(phi - step)) / (2 * eps)
        torch.testing.assert_close(grad[:, i], numeric, rtol=1e-5, atol=1e-7)
    assert all(p.grad is None for p in learner.parameters())


def test_a_plan_reads_the_learners_value_once_and_moves_toward_a_higher_value() -> None:
    """`optimise_plan` expands V to first order where the initial plan ends (`TerminalValue.linearised`):
    the learner's value runs once per plan whatever K; with no reward to follow (the models predict r̂ = 0
    for every action), K steps raise the expanded γ^H V of where the plan ends."""
    from core.dual.planning import TerminalValue

    bank, nodes, phi, plan = _random_setup()
    for name in ("wr", "br"):
        bank.params[name].zero_()
    calls = []
    direction = np.array([1.0, -0.5, 0.2, 0.3])

    def value(latent: np.ndarray) -> tuple[float, np.ndarray]:
        calls.append(latent.copy())
        return float(direction @ latent), direction

    rollout = Rollout(latents=phi[None].repeat(4, 1), actions=plan, rewards=torch.zeros(4),
                      next_latents=phi[None].repeat(4, 1), nodes=nodes)
    result = optimise_plan(phi, rollout, bank, PLANNER["value"], steps=10, lr=0.05,
                           terminal=TerminalValue(value, discount=0.99))
    assert len(calls) == 1
    assert result.final_loss < result.initial_loss  # the loss is −γ^H V (no reward): V went up
