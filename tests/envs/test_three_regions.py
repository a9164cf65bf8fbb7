"""ThreeRegions (core/envs/three_regions.py), the intrinsic-reward check's controlled problem."""

from __future__ import annotations

import csv

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

from core.config import load_config
from core.envs import THREE_REGIONS_ID, ThreeRegionsEnv
from core.envs.three_regions import REGIONS, region_of
from core.runs.trainer import train


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


def test_the_learnable_screen_follows_frequency_and_action_gain() -> None:
    env = ThreeRegionsEnv(frequency=1.0, action_gain=0.5)
    env.reset(seed=0)
    _place(env, 0.1, 0.5)
    screen = env.step(np.array([0.4, -0.2], dtype=np.float32))[0][2]
    np.testing.assert_allclose(screen, np.sin(0.1 + 0.5 * 0.4) * np.cos(0.5 + 0.5 * 0.2), rtol=1e-5)


def test_episodes_truncate_after_max_steps() -> None:
    env = ThreeRegionsEnv(max_steps=3)
    env.reset(seed=0)
    flags = [env.step(np.zeros(2, dtype=np.float32))[3] for _ in range(3)]
    assert flags == [False, False, True]


def test_episode_diagnostics_count_noise_steps_and_cells_outside_the_noise(tmp_path) -> None:
    """The last step's ``episode_diagnostics`` (the noisy TV's measures, issue 29) equal a count over the
    episode's own positions, and the trainer writes them into metrics.csv."""
    env = ThreeRegionsEnv(max_steps=120)
    obs, _ = env.reset(seed=3)
    positions, regions = [obs[:2].astype(np.float64)], []
    rng = np.random.default_rng(0)
    for step in range(120):
        action = np.array([1.0, rng.uniform(-1, 1)]) if step < 60 else np.array([-1.0, rng.uniform(-1, 1)])
        obs, _, _, truncated, info = env.step(action.astype(np.float32))
        positions.append(obs[:2].astype(np.float64))
        regions.append(info["region"])
        assert ("episode_diagnostics" in info) == truncated
    measured = info["episode_diagnostics"]
    assert measured["env/noise_share"] == regions.count("noise") / 120 and 0 < measured["env/noise_share"] < 1
    cells = {tuple(np.minimum(((p + 1) / 2 * 15).astype(int), 14)) for p in positions}
    rest = {cell for cell in cells if cell[0] < 10}  # columns 10-14 lie in the noise region, x >= 1/3
    assert measured["env/coverage_rest"] == len(rest) / 150

    overrides = [f"env.id={THREE_REGIONS_ID}", "run.algo=ddpg", "run.steps=400", "run.episodes=none",
                 "run.eval_every=0", "run.final_eval=false"]
    train(load_config("vector", overrides), tmp_path / "run", command="test")
    rows = list(csv.DictReader((tmp_path / "run" / "metrics.csv").open()))
    assert len(rows) == 2
    assert all(0.0 <= float(row["env/noise_share"]) <= 1.0 for row in rows)
    assert all(0.0 < float(row["env/coverage_rest"]) <= 1.0 for row in rows)
