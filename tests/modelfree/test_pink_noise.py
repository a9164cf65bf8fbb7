"""Pink action noise (``agent.noise=pink``) from the package ``pink-noise-rl``: DDPG/TD3/CACLA add σ times
the package's ``PinkNoiseProcess`` (a new sequence every episode, from the run's generator), SAC takes its ε
of acting from the same process (as the package's ``PinkNoiseDist``); its spectrum is pink; a seed
reproduces a run and a resumed run goes on with the same noise; a dual-system method explores with it too."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from pink import PinkNoiseProcess

from core.config import load_config
from core.envs.spec import EnvSpec
from core.modelfree.learners import make_learner
from core.modelfree.noise import PinkNoise, resolve_noise
from core.runs.trainer import train
from tests.utils.run_dirs import metrics_rows

SPEC = EnvSpec(obs_shape=(2,), action_dim=2, obs_kind="vector", obs_dtype="float32")
SMALL = ["net.mlp_hidden=16,16", "agent.warmup=policy"]


def make(ac: str, *extra: str):
    torch.manual_seed(0)
    config = load_config("vector", [*SMALL, f"agent.ac={ac}", "agent.noise=pink", *extra])
    return make_learner(config.net, config.agent, SPEC)


def package_noise(seed: int, lengths: list[int], seq_len: int, dim: int = 2) -> list[np.ndarray]:
    """The package's process on a generator of ``seed``: ``lengths[k]`` samples of episode k, reset
    between."""
    process = PinkNoiseProcess(size=(dim, seq_len), rng=np.random.default_rng(seed))
    episodes = []
    for k, length in enumerate(lengths):
        if k:
            process.reset()
        episodes.append(np.stack([process.sample() for _ in range(length)]))
    return episodes


LENGTHS = [40, 90, 25]
"""Episode lengths; the second is longer than the sequence (the package starts a fresh one)."""


@pytest.mark.parametrize("ac", ["ddpg", "td3", "cacla"])
def test_deterministic_learners_add_sigma_times_the_packages_process(ac):
    learner = make(ac, "agent.noise_seq_len=64", "agent.noise_std=0.3", "agent.noise_final_std=0.1",
                   "agent.noise_anneal_steps=200")
    assert isinstance(learner.noise, PinkNoise)
    rng = np.random.default_rng(7)
    action = np.array([0.2, -0.1], dtype=np.float32)
    latent = torch.zeros(2)
    step = 0
    for expected in package_noise(7, LENGTHS, 64):
        learner.begin_episode()
        for x in expected:
            sigma = learner.noise.std_at(step)
            want = np.clip(action + sigma * x, -1.0, 1.0).astype(np.float32)
            np.testing.assert_array_equal(learner.explore(action, latent, step, rng), want)
            step += 1
    assert learner.noise.std_at(step) < 0.3  # annealed as the Gaussian noise


def test_sac_acts_with_the_packages_process_as_its_epsilon():
    learner = make("sac", "agent.noise_seq_len=64")
    rng = np.random.default_rng(3)
    latent = torch.randn(2)
    with torch.no_grad():
        mean, log_std = learner.actor.distribution(latent.reshape(1, -1))
    std = log_std[0].exp().numpy().astype(np.float64)
    chosen = np.array([0.5, -0.3], dtype=np.float32)  # a planner's action: the Gaussian re-centred on it
    centre = np.arctanh(chosen.astype(np.float64))
    mu = learner.policy(latent.reshape(1, -1))[0].numpy()
    step = 10_000
    for expected in package_noise(3, LENGTHS, 64):
        learner.begin_episode()
        for x in expected:
            np.testing.assert_array_equal(
                learner.explore(chosen, latent, step, rng), np.tanh(centre + std * x).astype(np.float32)
            )
    # around the actor's own action a* = tanh(m): tanh(m + σ ε_pink), PinkNoiseDist's sample
    np.testing.assert_allclose(np.arctanh(mu), mean[0].numpy(), atol=1e-5)


def test_sac_sample_equals_pink_noise_dist_of_the_package():
    pytest.importorskip("stable_baselines3", reason="PinkNoiseDist is pink-noise-rl's SB3 part (bench extra)")
    from pink import PinkNoiseDist

    learner = make("sac", "agent.noise_seq_len=32")
    latent = torch.randn(2)
    with torch.no_grad():
        mean, log_std = learner.actor.distribution(latent.reshape(1, -1))
    mu = learner.policy(latent.reshape(1, -1))[0].numpy()
    dist = PinkNoiseDist(32, 2, rng=np.random.default_rng(5))  # 2.0.1: (seq_len, action_dim)
    ours_rng = np.random.default_rng(5)
    learner.begin_episode()
    for step in range(50):
        with torch.no_grad():
            theirs = dist.proba_distribution(mean, log_std).sample()[0].numpy()
        ours = learner.explore(mu, latent, 10_000 + step, ours_rng)
        np.testing.assert_allclose(ours, theirs, atol=2e-5)


def test_gaussian_sac_has_no_pink_process_and_keeps_its_state_empty():
    torch.manual_seed(0)
    config = load_config("vector", [*SMALL, "agent.ac=sac"])
    learner = make_learner(config.net, config.agent, SPEC)
    assert learner.pink is None and learner.extra_state() == {}


def low_frequency_share(series: np.ndarray, bins: int = 10) -> float:
    """The share of the (non-DC) power in the lowest ``bins`` frequencies of ``series`` ``[T, dim]``."""
    power = np.abs(np.fft.rfft(series - series.mean(axis=0), axis=0)) ** 2
    return float(power[1 : bins + 1].sum() / power[1:].sum())


def test_pink_noise_has_more_low_frequency_power_than_white_noise():
    T = 1000
    pink = make("ddpg", f"agent.noise_seq_len={T}", "agent.noise_std=0.2", "agent.noise_final_std=0.2")
    torch.manual_seed(0)
    config = load_config(
        "vector", [*SMALL, "agent.ac=ddpg", "agent.noise_std=0.2", "agent.noise_final_std=0.2"]
    )
    white = make_learner(config.net, config.agent, SPEC)
    zero, latent = np.zeros(2, dtype=np.float32), torch.zeros(2)
    shares = {}
    for name, learner in (("pink", pink), ("white", white)):
        rng = np.random.default_rng(11)
        values = []
        for _ in range(4):
            learner.begin_episode()
            values.append(np.stack([learner.explore(zero, latent, t, rng) for t in range(T)]))
        shares[name] = np.mean([low_frequency_share(v) for v in values])
    # white noise: 10 of 500 bins ≈ 2 %; pink (1/f): about half the power below f = 0.01
    assert shares["white"] < 0.05
    assert shares["pink"] > 0.25 and shares["pink"] > 8 * shares["white"]


TINY_RUN = [
    "env.id=MountainCarContinuous-v0",
    'env.kwargs={"max_episode_steps": 60}',
    "env.success=terminated",
    "net.mlp_hidden=16,16",
    "agent.noise=pink",
    "agent.learning_starts=80",
    "agent.batch_size=16",
    "agent.buffer_size=2000",
    "run.episodes=none",
    "run.eval_every=0",
    "run.eval_episodes=1",
    "run.final_eval=false",
    "run.checkpoint_every=2",
]


def rows(run_dir) -> list[dict[str, str]]:
    return metrics_rows(run_dir, without_wall_clock=True)


def test_the_sequence_length_is_the_envs_step_limit():
    config = load_config("vector", TINY_RUN)
    assert config.agent.noise_seq_len is None and resolve_noise(config).noise_seq_len == 60
    assert resolve_noise(load_config("vector", [*TINY_RUN, "agent.noise_seq_len=7"])).noise_seq_len == 7
    gaussian = load_config("vector", [*TINY_RUN, "agent.noise=gaussian"])
    assert resolve_noise(gaussian) is gaussian.agent


@pytest.mark.parametrize("algo", ["sac", "ddpg"])
def test_same_seed_same_run_other_seed_other_run_and_resume_continues(tmp_path, algo):
    def run(name: str, steps: int, *extra: str, resume: bool = False):
        config = load_config("vector", [*TINY_RUN, f"run.algo={algo}", f"run.steps={steps}", *extra])
        return train(config, tmp_path / name, resume=resume)

    run("a", 180)
    run("b", 180)
    run("c", 180, "run.seed=1")
    assert rows(tmp_path / "a") == rows(tmp_path / "b")
    assert [r["charts/episodic_return"] for r in rows(tmp_path / "a")] != [
        r["charts/episodic_return"] for r in rows(tmp_path / "c")
    ]
    run("split", 120)
    run("split", 180, resume=True)
    assert rows(tmp_path / "split") == rows(tmp_path / "a")


def test_a_dual_system_method_explores_with_pink_noise(tmp_path):
    from core.runs.methods import make_agent

    config = load_config("vector", [*TINY_RUN, "run.algo=im2c", "agent.ac=ddpg", "run.steps=120"])
    agent = make_agent(config, SPEC_MC, np.random.default_rng(0))
    assert isinstance(agent.learner.noise, PinkNoise) and agent.learner.noise.seq_len == 60
    summary = train(config, tmp_path / "im2c")
    assert summary["steps"] == 120


SPEC_MC = EnvSpec(obs_shape=(2,), action_dim=1, obs_kind="vector", obs_dtype="float32",
                  obs_low=(-1.2, -0.07), obs_high=(0.6, 0.07))
