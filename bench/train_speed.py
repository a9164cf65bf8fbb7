"""Benchmark: milliseconds per training step (one env step + one minibatch update), ours vs SB3's DDPG.

Methods (``--algos``):

* ``ddpg`` / ``cacla`` — dualsys' model-free agent with the default profile (strided encoder, critic-
  autoencoder update of Eq. 4 incl. the decoder, actor update, τ targets), per-step schedule.
* any other registered method (``im2c``, ``i2a``, ``mve``, ``cmc``, ``la-imagination``) — its default-profile
  agent, per-step schedule, the same loop (so a dual-system step includes its meta-control, model learning
  and, for I2A, the pixel + latent update).
* ``sb3-ddpg`` — Stable-Baselines3's DDPG (the tool a user would pick instead) on the same env with the
  same encoder shape (our encoder as its features extractor: the conv stack + dense to 32 for images, the
  MLP to 32 for vectors), heads of 20 units, the same batch size and buffer size, ``train_freq=1,
  gradient_steps=1``. SB3 has no decoder and gives actor and critic separate encoders (its default for
  DDPG).

``env`` is any gymnasium id (default NicoGrasp); e.g. ``MountainCarContinuous-v0`` times the methods on a
vector task, where the env step is nearly free and the figures are the learners' own cost.

Each method first collects ``warmup`` steps without updates (learning_starts), then ``steps`` timed
steps with one update each; ``rounds`` alternate the methods and the median per method is reported.
Output: ``{"ddpg": {"ms_per_step": ..., "batch": ...}, "sb3-ddpg": {...}, "threads": ...}``.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

import numpy as np
import torch

from core.config import Config, load_config
from core.modelfree.agent import Transition
from core.runs.methods import make_agent
from core.runs.trainer import make_env

METHODS = ("ddpg", "cacla", "td3", "sac", "sb3-ddpg", "sb3-td3", "sb3-sac")
"""The model-free methods and the SB3 reference; every method in ``core.runs.methods`` is accepted too."""


def known_methods() -> tuple[str, ...]:
    """``METHODS`` plus every method in ``core.runs.methods.ALGOS``."""
    from core.runs.methods import ALGOS

    return tuple(dict.fromkeys((*METHODS, *sorted(ALGOS))))


def _config(
    algo: str,
    batch: int | None,
    buffer: int,
    env: str | None = None,
    profile: str = "default",
    settings: tuple[str, ...] = (),
) -> Config:
    """The timed config: ``profile`` with the bench's own keys, then the user's ``settings`` (KEY=VALUE)."""
    overrides = [
        f"run.algo={algo}",
        *([f"env.id={env}"] if env else []),
        f"agent.buffer_size={buffer}",
        "agent.update_schedule=per_step",
        "agent.updates_per_step=1",
    ]
    if batch is not None:
        overrides.append(f"agent.batch_size={batch}")
    return load_config(profile, [*overrides, *settings])


def _ours(
    algo: str,
    batch: int | None,
    buffer: int,
    warmup: int,
    steps: int,
    seed: int,
    env_id: str | None = None,
    profile: str = "default",
    settings: tuple[str, ...] = (),
) -> tuple[float, int]:
    config = _config(algo, batch, buffer, env_id, profile, settings)
    config.agent.learning_starts = warmup
    torch.manual_seed(seed)
    adapted = make_env(config)
    env = adapted.env
    agent = make_agent(config, adapted.spec, np.random.default_rng(seed))
    obs, _ = env.reset(seed=seed)
    agent.begin_episode(obs)
    start = 0.0
    for step in range(warmup + steps):
        if step == warmup:
            start = time.perf_counter()
        action, _ = agent.act(obs, explore=True)
        next_obs, reward, terminated, truncated, _ = env.step(action)
        agent.observe(Transition(obs, action, reward, next_obs, terminated, truncated))
        agent.update_after_step()
        obs = next_obs
        if terminated or truncated:
            obs, _ = env.reset()
            agent.begin_episode(obs)
    elapsed = time.perf_counter() - start
    env.close()
    return 1000.0 * elapsed / steps, config.agent.batch_size


def _sb3(
    algo: str, batch: int | None, buffer: int, warmup: int, steps: int, seed: int, env_id: str | None = None
) -> tuple[float, int]:
    """SB3's ``algo`` (ddpg, td3, sac) with our encoder and head sizes as its networks."""
    try:
        import stable_baselines3
        from stable_baselines3.common.callbacks import BaseCallback
        from stable_baselines3.common.noise import NormalActionNoise
        from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
    except ImportError as exc:  # the bench extra is not installed
        raise ValueError(f"sb3-{algo} needs stable-baselines3: pip install -e '.[bench]'") from exc

    from core.modelfree.networks import Encoder, head_sizes, make_encoder

    config = _config(algo, batch, buffer, env_id)
    adapted = make_env(config)
    spec = adapted.spec

    class SameEncoder(BaseFeaturesExtractor):
        """Our encoder shape as SB3's features extractor (SB3 feeds images as CHW floats in [0, 1], vectors
        as they are, which our vector encoder scales)."""

        def __init__(self, observation_space: Any) -> None:
            encoder = make_encoder(config.net, spec, algo)
            super().__init__(observation_space, features_dim=encoder.latent_dim)
            self.encoder = encoder

        def forward(self, observations: torch.Tensor) -> torch.Tensor:
            if isinstance(self.encoder, Encoder):
                return self.encoder(observations)
            return self.encoder(self.encoder.prepare(observations))

    class Timer(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.start: float | None = None

        def _on_step(self) -> bool:
            if self.num_timesteps == warmup:
                self.start = time.perf_counter()
            return True

    env = adapted.env
    action_dim = spec.action_dim
    actor_hidden, critic_hidden = head_sizes(config.net, spec)
    noise = NormalActionNoise(np.zeros(action_dim), np.full(action_dim, config.agent.noise_std))
    model = getattr(stable_baselines3, algo.upper())(
        "CnnPolicy" if spec.obs_kind == "image" else "MlpPolicy",
        env,
        learning_rate=config.agent.critic_lr,
        buffer_size=buffer,
        learning_starts=warmup,
        batch_size=config.agent.batch_size,
        tau=config.agent.tau,
        gamma=config.agent.gamma,
        train_freq=1,
        gradient_steps=1,
        **({} if algo == "sac" else {"action_noise": noise}),
        policy_kwargs={
            "features_extractor_class": SameEncoder,
            "net_arch": {"pi": list(actor_hidden), "qf": list(critic_hidden)},
            "normalize_images": spec.obs_kind == "image",
        },
        seed=seed,
        device="cpu",
        verbose=0,
    )
    timer = Timer()
    model.learn(total_timesteps=warmup + steps, callback=timer)
    elapsed = time.perf_counter() - (timer.start or time.perf_counter())
    env.close()
    return 1000.0 * elapsed / steps, config.agent.batch_size


def measure(
    algos: tuple[str, ...] = ("ddpg", "sb3-ddpg"),
    batch: int | None = None,
    steps: int = 300,
    warmup: int = 300,
    rounds: int = 2,
    buffer: int = 100_000,
    seed: int = 0,
    threads: int | None = None,
    env: str | None = None,
    profile: str = "default",
    settings: tuple[str, ...] = (),
) -> dict[str, Any]:
    """ms per training step for each method (median over ``rounds`` alternating rounds) on ``env``.

    ``threads``: torch threads for both (default: the default profile's ``run.num_threads``). ``profile``
    and ``settings`` (KEY=VALUE overrides, after the bench's own) shape our methods only; SB3's methods keep
    the default profile's sizes. E.g. the cost of the progress planner against SB3-default SAC on
    MountainCar: ``profile="vector"``, ``algos=("sac", "im2c")``, ``settings=("agent.ac=sac",
    "dual.planner=progress", "net.mlp_hidden=[256,256]", "agent.batch_size=256")`` (``dual.*`` is inert for
    ``sac``).
    """
    if threads is None:
        threads = load_config("default").run.num_threads
    known = known_methods()
    unknown = [name for name in algos if name not in known]
    if unknown:
        raise ValueError(f"unknown bench method {unknown[0]!r} (choose from {', '.join(known)})")
    torch.set_num_threads(threads)
    samples: dict[str, list[float]] = {name: [] for name in algos}
    batches: dict[str, int] = {}
    for _ in range(rounds):
        for name in algos:
            if name.startswith("sb3-"):
                ms, used_batch = _sb3(name.removeprefix("sb3-"), batch, buffer, warmup, steps, seed, env)
            else:
                ms, used_batch = _ours(name, batch, buffer, warmup, steps, seed, env, profile, settings)
            samples[name].append(ms)
            batches[name] = used_batch
    result: dict[str, Any] = {
        name: {
            "ms_per_step": round(statistics.median(values), 2),
            "batch": batches[name],
            "rounds_ms": [round(v, 2) for v in values],
        }
        for name, values in samples.items()
    }
    result["env"] = env or "dualsys/NicoGrasp-v0"
    result["profile"] = profile
    result["settings"] = list(settings)
    result["threads"] = threads
    result["timed_steps"] = steps
    return result
