"""NicoGrasp behaviour: the task is solvable, verification is right, outcomes and errors are as specified."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import core.envs  # noqa: F401  (registers the gymnasium id)
from core.envs import ENV_ID, NicoGraspEnv, run_oracle


@pytest.fixture
def env():
    environment = NicoGraspEnv()
    yield environment
    environment.close()


@pytest.mark.parametrize("hand", ["auto", "learned"])
def test_gymnasium_env_checker_passes(hand):
    environment = gym.make(ENV_ID, hand=hand)
    check_env(environment.unwrapped, skip_render_check=True)
    environment.close()


def test_spaces_follow_the_hand_mode():
    auto, learned = NicoGraspEnv(hand="auto"), NicoGraspEnv(hand="learned")
    assert auto.observation_space.shape == (32, 64, 3) and auto.observation_space.dtype == np.uint8
    assert auto.action_space.shape == (1,)
    assert learned.action_space.shape == (2,)
    assert auto.grasp_threshold == pytest.approx(0.03) and learned.grasp_threshold == pytest.approx(0.04)
    auto.close()
    learned.close()


@pytest.mark.parametrize("hand", ["auto", "learned"])
@pytest.mark.parametrize("reward_mode", ["dense", "sparse"])
def test_scripted_oracle_solves_the_task(hand, reward_mode):
    environment = NicoGraspEnv(hand=hand, reward_mode=reward_mode)
    result = run_oracle(environment, episodes=100, seed=0)
    environment.close()
    assert result["oracle_success_rate"] >= 0.95, result


def test_sweeping_through_the_glass_topples_it(env):
    # Glass 29° ahead of the start angle: the first +20° step stops short, the second sweeps through it.
    env.reset(seed=0, options={"glass_angle_deg": 62.0})
    _, reward, terminated, _, info = env.step(np.array([1.0], np.float32))
    assert not terminated and not info["grasp_attempted"]
    _, reward, terminated, truncated, info = env.step(np.array([1.0], np.float32))
    assert info["toppled"] and not info["success"]
    assert reward == -1.0 and terminated and not truncated


def test_closing_far_from_the_glass_is_a_failed_attempt_and_the_episode_goes_on():
    environment = NicoGraspEnv(hand="learned")
    _, info0 = environment.reset(seed=3)
    _, reward, terminated, truncated, info = environment.step(np.array([0.0, 1.0], np.float32))
    assert info["grasp_attempted"] and not info["success"] and not info["toppled"]
    assert not terminated and not truncated
    assert reward == pytest.approx(-info["distance"])
    # The glass is back where it stood and the shoulder is back where it was.
    assert np.allclose(info["glass_pos"], info0["glass_pos"], atol=2e-3)
    assert info["shoulder_deg"] == pytest.approx(info0["shoulder_deg"], abs=0.5)
    environment.close()


def test_episode_truncates_at_max_steps(env):
    env.reset(seed=1)
    for step in range(1, 51):
        _, _, terminated, truncated, _ = env.step(np.array([0.0], np.float32))
        assert not terminated
        assert truncated == (step == 50)


@pytest.mark.parametrize(
    ("shaping", "transform"), [("distance", lambda d: -d), ("squared", lambda d: -(d * d))]
)
def test_dense_reward_shaping(shaping, transform):
    environment = NicoGraspEnv(dense_shaping=shaping)
    environment.reset(seed=2)
    _, reward, _, _, info = environment.step(np.array([0.0], np.float32))
    assert reward == pytest.approx(transform(info["distance"]))
    environment.close()


def test_sparse_reward_is_zero_until_an_outcome():
    environment = NicoGraspEnv(reward_mode="sparse")
    environment.reset(seed=2)
    _, reward, _, _, _ = environment.step(np.array([0.0], np.float32))
    assert reward == 0.0
    environment.close()


def test_a_verified_grasp_pays_one_and_ends_the_episode(env):
    env.reset(seed=0, options={"glass_angle_deg": 50.0})
    delta = env.last_info["grasp_angle_deg"] - env.last_info["shoulder_deg"]
    _, reward, terminated, _, info = env.step(np.array([delta / 20.0], np.float32))
    assert info["grasp_attempted"] and info["success"]
    assert reward == 1.0 and terminated


def test_same_seed_same_observations():
    a, b = NicoGraspEnv(domain="real"), NicoGraspEnv(domain="real")
    obs_a, _ = a.reset(seed=11)
    obs_b, _ = b.reset(seed=11)
    np.testing.assert_array_equal(obs_a, obs_b)
    actions = np.random.default_rng(0).uniform(-1, 1, size=(15, 1)).astype(np.float32)
    for action in actions:
        out_a, out_b = a.step(action), b.step(action)
        np.testing.assert_array_equal(out_a[0], out_b[0])
        assert out_a[1:4] == out_b[1:4]
        if out_a[2] or out_a[3]:
            break
    other, _ = a.reset(seed=12)
    assert not np.array_equal(other, obs_a)
    a.close()
    b.close()


def test_sim_and_real_views_of_one_state_differ_but_correlate(env):
    env.reset(seed=4)
    sim = env.render_observation("sim").astype(np.float64)
    real = env.render_observation("real").astype(np.float64)
    assert np.abs(sim - real).mean() > 5.0
    correlation = np.corrcoef(sim.mean(axis=2).ravel(), real.mean(axis=2).ravel())[0, 1]
    assert correlation > 0.5


def test_fixed_positions_cycle_over_episodes():
    environment = NicoGraspEnv(fixed_positions=3)
    positions = [environment.reset(seed=0 if i == 0 else None)[1]["glass_pos"] for i in range(4)]
    assert positions[0] == positions[3]
    assert len({positions[0], positions[1], positions[2]}) == 3
    environment.close()


def test_random_positions_are_graspable(env):
    low, high = (math.degrees(v) for v in env.glass_window_rad)
    for seed in range(20):
        _, info = env.reset(seed=seed)
        assert low - 0.5 <= info["grasp_angle_deg"] <= high + 0.5


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"reward_mode": "shaped"}, "reward_mode"), ({"hand": "both"}, "hand"), ({"domain": "mars"}, "domain")],
)
def test_bad_arguments_are_clear_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        NicoGraspEnv(**kwargs)


@pytest.mark.parametrize(
    "action", [np.zeros(2, np.float32), np.array([np.nan], np.float32), np.zeros((1, 1))]
)
def test_bad_actions_are_clear_errors(env, action):
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)


def test_on_the_full_window_the_arm_is_out_of_view_below_minus_ten_degrees():
    """docs/environment.md, "What the camera sees of the arm": on the `paper` and `hard` levels' ±100° window
    the image of shoulder angles from −100° to −10° is the image at −100° up to a few pixels one intensity
    level off; the arm comes into view between −10° and 0°."""
    environment = NicoGraspEnv(level="hard", hand="learned", max_steps=1000)
    try:
        environment.reset(seed=5)
        push_down, creep_up = np.array([-1.0, -1.0], np.float32), np.array([0.25, -1.0], np.float32)
        for _ in range(6):
            obs, *_ = environment.step(push_down)
        assert math.degrees(environment._shoulder_angle()) == pytest.approx(-100.0, abs=0.5)
        out_of_view = obs.astype(int)
        changed: dict[int, tuple[int, int]] = {}
        while math.degrees(environment._shoulder_angle()) < 9.5:
            obs, *_ = environment.step(creep_up)
            difference = np.abs(obs.astype(int) - out_of_view)
            changed[round(math.degrees(environment._shoulder_angle()))] = (int(difference.any(-1).sum()),
                                                                           int(difference.max()))
        hidden = [v for angle, v in changed.items() if angle <= -10]
        seen = [v for angle, v in changed.items() if angle >= 0]
        assert len(hidden) == 18 and all(pixels <= 3 and level <= 1 for pixels, level in hidden)
        assert len(seen) == 3 and all(pixels >= 15 and level >= 40 for pixels, level in seen)
    finally:
        environment.close()
