"""The 8-step grasp-trial evaluator: Wilson interval, counting, the 8-step stop, the Robot protocol."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.deploy import (
    MotorResult,
    Robot,
    SimRobot,
    TrialReport,
    run_grasp_trials,
    wilson_interval,
)
from core.envs import oracle_action


def test_wilson_interval_matches_the_closed_form_and_known_values():
    assert wilson_interval(25, 25) == pytest.approx((0.8668, 1.0), abs=1e-4)
    assert wilson_interval(0, 25) == pytest.approx((0.0, 0.1332), abs=1e-4)
    assert wilson_interval(10, 20) == pytest.approx((0.2993, 0.7007), abs=1e-4)
    n, k, z = 25, 19, 1.959963984540054
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    assert wilson_interval(k, n) == pytest.approx((centre - half, centre + half))
    low, high = wilson_interval(k, n)
    assert low < p < high
    with pytest.raises(ValueError):
        wilson_interval(0, 0)
    with pytest.raises(ValueError):
        wilson_interval(26, 25)


class CountingPolicy:
    """A scripted policy (not a dualsys component) that counts its calls."""

    def __init__(self, act):
        self.act = act
        self.calls = 0
        self.shapes: set[tuple[int, ...]] = set()

    def __call__(self, images: np.ndarray) -> np.ndarray:
        self.calls += 1
        self.shapes.add(images.shape)
        assert images.dtype == np.uint8
        return self.act(images)


def test_sim_robot_implements_the_robot_protocol():
    with SimRobot() as robot:
        assert isinstance(robot, Robot)
        assert robot.action_dim == 1
        with pytest.raises(RuntimeError):
            robot.capture_image()
        robot.place_object(3)
        image = robot.capture_image()
        assert image.dtype == np.uint8 and image.shape == (32, 64, 3)
        result = robot.execute(np.array([0.0], dtype=np.float32))
        assert isinstance(result, MotorResult) and not robot.verify_grasp()


def test_oracle_policy_scores_25_of_25_and_json_has_the_documented_keys():
    with SimRobot() as robot:
        policy = CountingPolicy(lambda images: oracle_action(robot.env, robot.last_info)[None])
        report = run_grasp_trials(policy, robot, trials=25, max_steps=8, seed=100)
    assert isinstance(report, TrialReport)
    assert (report.trials, report.successes, report.success_rate) == (25, 25, 1.0)
    assert report.ci_low == pytest.approx(0.8668, abs=1e-4) and report.ci_high == 1.0
    assert all(t.success and t.outcome == "grasped" and 1 <= t.steps <= 8 for t in report.per_trial)
    assert all(t.grasp_attempts >= 1 for t in report.per_trial)
    assert policy.calls == sum(t.steps for t in report.per_trial)
    assert policy.shapes == {(1, 32, 64, 3)}
    assert [t.seed for t in report.per_trial] == list(range(100, 125))
    data = report.to_dict()
    assert {"trials", "successes", "success_rate", "ci_low", "ci_high", "per_trial"} <= set(data)
    assert len(data["per_trial"]) == 25 and data["per_trial"][0]["trial"] == 1


def test_a_policy_that_never_reaches_scores_0_and_every_trial_stops_at_8_steps():
    with SimRobot() as robot:
        policy = CountingPolicy(lambda images: -np.ones((len(images), 1), dtype=np.float32))
        report = run_grasp_trials(policy, robot, trials=25, max_steps=8, seed=0)
    assert report.successes == 0 and report.success_rate == 0.0
    assert report.ci_low == 0.0 and report.ci_high == pytest.approx(0.1332, abs=1e-4)
    assert all(t.steps == 8 and t.outcome == "step limit" for t in report.per_trial)
    assert policy.calls == 25 * 8


def test_learned_hand_oracle_grasps_and_a_never_closing_policy_scores_0():
    with SimRobot(hand="learned") as robot:
        assert robot.action_dim == 2
        grasping = run_grasp_trials(lambda images: oracle_action(robot.env, robot.last_info)[None], robot,
                                    trials=25, seed=7)

        def never_close(images: np.ndarray) -> np.ndarray:
            action = oracle_action(robot.env, robot.last_info)
            action[1] = -1.0  # goes to the glass, never closes the hand
            return action[None]

        report = run_grasp_trials(never_close, robot, trials=25, seed=7)
    assert grasping.successes == 25
    assert report.successes == 0
    assert all(t.grasp_attempts == 0 and t.steps <= 8 for t in report.per_trial)
    assert all(t.steps == 8 for t in report.per_trial if t.outcome == "step limit")


def test_max_steps_bounds_each_trial_and_bad_arguments_raise():
    with SimRobot() as robot:
        report = run_grasp_trials(lambda images: np.zeros((1, 1), np.float32), robot, trials=3, max_steps=3)
        assert [t.steps for t in report.per_trial] == [3, 3, 3]
        with pytest.raises(ValueError, match="2-d actions"):
            run_grasp_trials(lambda images: np.zeros((1, 2), np.float32), robot, trials=1)
        with pytest.raises(ValueError):
            run_grasp_trials(lambda images: np.zeros((1, 1), np.float32), robot, trials=0)
        with pytest.raises(ValueError):
            run_grasp_trials(lambda images: np.zeros((1, 1), np.float32), robot, max_steps=0)


def test_real_domain_robot_sees_the_same_state_through_another_camera():
    with SimRobot(domain="sim") as sim, SimRobot(domain="real") as real:
        sim.place_object(11)
        real.place_object(11)
        assert sim.last_info["glass_pos"] == real.last_info["glass_pos"]
        difference = np.abs(sim.capture_image().astype(int) - real.capture_image().astype(int)).mean()
        assert difference > 3.0
