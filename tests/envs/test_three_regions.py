"""ThreeRegions (core/envs/three_regions.py), the intrinsic-reward check's controlled problem."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

from core.envs import THREE_REGIONS_ID, ThreeRegionsEnv
from core.envs.three_regions import REGIONS, region_of


def _place(env: ThreeRegionsEnv, x: float, y: float, screen: float = 0.3) -> None:
    env._position = np.array([x, y])
    env._screen = screen


def test_registered_and_passes_the_gymnasium_checker() -> None:
    env = gym.make(THREE_REGIONS_ID)
    check_env(env.unwrapped)
    obs, info = env.reset(seed=1)
    assert obs.shape == (3,) and info["region"] in REGIONS
    env.close()


def test_the_three_regions_dynamics() -> None:
    env = ThreeRegionsEnv()
    env.reset(seed=0)
    action = np.array([0.4, -0.2], dtype=np.float32)
    _place(env, -0.8, 0.1)
    obs, reward, terminated, truncated, info = env.step(action)
    assert info["region"] == "trivial" and obs[2] == np.float32(0.3)  # the screen keeps its value
    np.testing.assert_allclose(obs[:2], [-0.8 + 0.05 * 0.4, 0.1 - 0.05 * 0.2], atol=1e-6)
    assert reward == 0.0 and not terminated and not truncated
    screens = []
    for _ in range(2):
        _place(env, 0.0, 0.5)
        screens.append(env.step(action)[0][2])
    assert screens[0] == screens[1]  # deterministic: sin(2x + 2a_x) · cos(2y − 2a_y)
    np.testing.assert_allclose(screens[0], np.sin(2 * 0.4) * np.cos(2 * 0.5 + 2 * 0.2), rtol=1e-5)
    noise = []
    for _ in range(20):
        _place(env, 0.8, 0.0)
        obs, *_, info = env.step(action)
        noise.append(obs[2])
    assert info["region"] == "noise" and np.std(noise) > 0.3  # the noisy TV
    assert region_of(np.array([-0.5, 0.0, 0.5])).tolist() == [0, 1, 2]


def test_episodes_truncate_after_max_steps() -> None:
    env = ThreeRegionsEnv(max_steps=3)
    env.reset(seed=0)
    flags = [env.step(np.zeros(2, dtype=np.float32))[3] for _ in range(3)]
    assert flags == [False, False, True]
