"""Goal babbling (`core.dual.goal_babbling`): a share of an aiming planner's goals drawn past the map's
edge."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from core.dual.goal_babbling import FLOOR, PATIENCE, REACH, SHARE, GoalBabbling
from core.dual.region_goal import RegionGoal

CENTRES = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 2.0]])
AIM = RegionGoal(CENTRES, np.array([0.1, 0.5, 0.2]))
FAR = np.array([50.0, 50.0])
"""An agent's position that no babbled goal is near (so a goal is held until the next pick)."""


def test_about_a_share_of_picks_babble_inside_the_widened_box_and_each_is_held_until_the_next_pick():
    babbling = GoalBabbling(seed=0)
    picks, babbled = 400, []
    for _ in range(picks):
        goals = [babbling.choose(AIM, FAR, margin=0.5).goal for _ in range(PATIENCE)]
        assert all(np.array_equal(goal, goals[0]) for goal in goals)  # one goal per pick, held
        if not np.array_equal(goals[0], AIM.goal):
            babbled.append(goals[0])
    share = len(babbled) / picks
    assert abs(share - SHARE) < 4 * np.sqrt(SHARE * (1 - SHARE) / picks), share  # binomial, 4 standard errors
    points = np.array(babbled)
    low, high = CENTRES.min(axis=0) - REACH * 0.5, CENTRES.max(axis=0) + REACH * 0.5
    assert (points >= low).all() and (points <= high).all()
    past_reach = ((points < CENTRES.min(axis=0) - 0.5) | (points > CENTRES.max(axis=0) + 0.5)).any(axis=1)
    assert 0.2 < past_reach.mean() < 0.9  # a fair part of the draws lies past e_max beyond the nodes' extent
    assert babbling.picks == len(babbled) and babbling.dropped_at_once == 0  # FAR is near no draw


def test_a_babbled_goal_keeps_the_aims_pull_and_is_dropped_once_reached():
    babbling = GoalBabbling(seed=0, share=1.0)
    first = babbling.choose(AIM, FAR, margin=0.5)
    assert not np.array_equal(first.goal, AIM.goal) and first.babbled
    assert first.weight == AIM.weight > FLOOR and first.values is AIM.values  # the aim's pull length
    assert AIM.goal is not None and not AIM.babbled  # the aim itself unchanged
    reached = babbling.choose(AIM, first.goal + 0.1, margin=0.5)  # within e_max of it
    np.testing.assert_array_equal(reached.goal, AIM.goal)
    assert babbling.goal is None
    with pytest.raises(ValueError):
        GoalBabbling(seed=0, share=1.5)


def test_where_the_aim_has_no_contrast_a_babbled_goal_still_pulls_with_the_floor_length():
    """Item 21: with all values equal the aim's own goal is nothing; a babbled goal pulls all the same, its
    length floored (a goal of length 0 is refused)."""
    flat = RegionGoal(CENTRES, np.full(3, 0.3))
    assert flat.goal is None and flat.weight == 0.0
    babbled = GoalBabbling(seed=0, share=1.0).choose(flat, FAR, margin=0.5)
    assert babbled.babbled and babbled.goal is not None and babbled.weight == FLOOR
    values, grads = babbled(np.zeros((1, 2)))
    assert values[0] < 0.0 and np.linalg.norm(grads) > 0.0  # it pulls toward the drawn point
    assert GoalBabbling(seed=0, share=0.0).choose(flat, FAR, margin=0.5) is flat  # no pick: no goal
    with pytest.raises(ValueError):
        flat.redirected(np.zeros(2))


def test_a_goal_drawn_where_the_agent_already_is_counts_as_dropped_at_once():
    """One node: with no widening every draw is the node itself, reached at once by an agent standing on it;
    widened by REACH e_max, most draws lie out of reach."""
    node = RegionGoal(np.array([[0.0, 0.0]]), np.array([0.5]))
    unwidened = GoalBabbling(seed=0, share=1.0, reach=0.0)
    for _ in range(20 * PATIENCE):
        assert unwidened.choose(node, np.zeros(2), margin=0.5).goal is None  # the aim has no contrast
    assert unwidened.picks == unwidened.dropped_at_once == 20
    widened = GoalBabbling(seed=0, share=1.0)
    for _ in range(200 * PATIENCE):
        widened.choose(node, np.zeros(2), margin=0.5)
    # uniform in a square of side 2 REACH e_max: the disc of radius e_max holds π / (2 REACH)² of it
    expected = np.pi / (2 * REACH) ** 2
    assert widened.picks == 200
    assert abs(widened.dropped_at_once / 200 - expected) < 4 * np.sqrt(expected * (1 - expected) / 200)


def test_with_babbled_goals_only_there_is_no_goal_between_them():
    """The ``babbling`` reading (the ablation): the aim's own goal never returns; between babbled goals the
    pull has no goal at all, so the actor (or the predicted return) decides."""
    babbling = GoalBabbling(seed=0, only=True)
    picks = 400
    goals = [babbling.choose(AIM, FAR, margin=0.5).goal for _ in range(picks * PATIENCE)]
    assert not any(goal is not None and np.array_equal(goal, AIM.goal) for goal in goals)
    held = np.mean([goal is not None for goal in goals])  # about SHARE of the decisions aim at a babbled goal
    assert abs(held - SHARE) < 4 * np.sqrt(SHARE * (1 - SHARE) / picks), held


def test_a_restored_state_continues_with_the_same_goals():
    babbling = GoalBabbling(seed=3)
    for _ in range(7 * PATIENCE + 13):
        babbling.choose(AIM, FAR, margin=0.5)
    restored = GoalBabbling(seed=99)
    restored.load_state_dict(babbling.state_dict())
    for _ in range(20 * PATIENCE):
        np.testing.assert_array_equal(babbling.choose(AIM, FAR, margin=0.5).goal,
                                      restored.choose(AIM, FAR, margin=0.5).goal)


def test_the_aiming_readings_babble_through_the_world_and_the_others_do_not():
    from core.config import load_config
    from core.dual.readings import resolve
    from core.dual.world_models import LocalWorldModels

    rng = np.random.default_rng(0)
    worlds = {}
    for planner in ("progress", "disagreement", "repaired", "babbling"):
        dual = load_config("default", [f"dual.planner={planner}"]).dual
        worlds[planner] = LocalWorldModels(dual, 3, 2, generator=torch.Generator().manual_seed(0),
                                           readings=resolve(dual))
    assert worlds["repaired"].goal_babbling is None
    world = worlds["progress"]
    assert world.goal_babbling is not None and worlds["disagreement"].goal_babbling is not None
    assert not world.goal_babbling.only and worlds["babbling"].goal_babbling.only
    for _ in range(200):
        world.observe_state(torch.tensor([*rng.uniform(-1.0, 1.0, size=2), 0.0], dtype=torch.float32))
    world.aim_values = lambda aim, regions: np.linspace(0.0, 1.0, regions.size)  # a contrast to aim at
    world.goal_babbling.share = 1.0
    phi = torch.tensor([30.0, 30.0, 0.0])  # far from every draw, so the babbled goal is not reached at once
    plain = world.aim_goal("progress")  # no latent: no decision, nothing babbled
    babbled = world.aim_goal("progress", None, phi)
    assert not np.array_equal(plain.goal, babbled.goal) and world.goal_babbling.decisions == 1
    state = world.state_dict()
    assert "goal_babbling" in state
    world.goal_babbling.decisions = 0
    world.load_state_dict(state)
    assert world.goal_babbling.decisions == 1


def test_a_trained_aiming_run_reports_its_aimed_and_babbled_decisions(tmp_path):
    """The loop's diagnostics of an aiming planner: ``dual/aimed_decisions``, ``dual/babbled_decisions`` (a
    part of them) and ``dual/aim_contrast`` (the mean pull length w) per episode; a planner without an aim
    writes none of them."""
    from core.config import load_config
    from core.runs.run_dir import MetricsCSV
    from core.runs.trainer import train

    common = ["env.id=dualsys/NoisyTV-v0", "run.algo=im2c", "agent.ac=sac", "run.steps=1200",
              "run.episodes=none", "run.eval_every=0", "run.final_eval=false", "agent.learning_starts=100"]
    train(load_config("vector", [*common, "dual.planner=progress"]), tmp_path / "aims", command="test")
    rows = MetricsCSV(tmp_path / "aims" / "metrics.csv").rows
    aimed = [float(row["dual/aimed_decisions"]) for row in rows]
    babbled = [float(row["dual/babbled_decisions"]) for row in rows]
    assert sum(aimed) > 0 and 0 < sum(babbled) < sum(aimed)
    assert all(b <= a <= 200 for a, b in zip(aimed, babbled, strict=True))
    contrasts = [float(row["dual/aim_contrast"]) for row in rows if float(row["dual/aimed_decisions"]) > 0]
    assert all(0.0 < w <= 1.0 for w in contrasts)
    # One 200-step episode writes the first row, which is all the absence of the columns needs.
    train(load_config("vector", [*common, "dual.planner=repaired", "run.steps=200"]), tmp_path / "plain",
          command="test")
    assert "dual/aimed_decisions" not in MetricsCSV(tmp_path / "plain" / "metrics.csv").rows[0]
