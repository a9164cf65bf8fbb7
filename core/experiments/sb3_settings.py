"""What a Stable-Baselines3 peer is built from: the algorithm, the policy (with our encoder as the features
extractor of images), the constructor arguments of a named setting, and their record.

``agent.sb3_hyperparams`` names the setting:

* ``dualsys`` (default) — SB3's defaults, with the warm-up, memory, minibatch and discount of our agents
  and Gaussian exploration noise for the deterministic-policy algorithms; every difference from SB3's
  defaults is in :data:`NON_DEFAULTS` (and docs/model-free.md, "A modern peer"). Images get SB3's
  ``CnnPolicy`` on :class:`DualsysEncoderExtractor`, vectors SB3's ``MlpPolicy`` as it comes (SB3's
  ``FlattenExtractor``; heads ``[256, 256]`` for SAC, ``[400, 300]`` for TD3 and DDPG — SB3's ``TD3Policy``
  gives ``[256, 256]`` only with its own ``NatureCNN``, so our image extractor gets ``[400, 300]`` heads too).
* ``zoo`` — RL Baselines3 Zoo's published hyperparameters for ``env.id`` (:mod:`core.experiments.sb3_zoo`).

``sb3-sac-pink`` is ``sb3-sac`` with one change, the package ``pink-noise-rl``'s example for SAC (Eberhard et
al., ICLR 2023): ``model.actor.action_dist = PinkNoiseDist(seq_len, action_dim)`` with ``seq_len`` the env's
step limit (:func:`use_pink_noise`; the generator is seeded with ``run.seed``). Either setting applies.

:func:`make_model` builds the SB3 model; :func:`hyperparams_record` is what the run writes to
``sb3_hyperparams.json``: the setting, its source, the arguments given and the values the built model
uses (SB3's defaults filled in), so a report can cite them.

Stable-Baselines3 is optional (the ``bench`` extra): this module imports it only inside functions, and a
missing SB3 is the one-line :class:`core.experiments.spec.ExperimentError` of :func:`require_sb3`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from torch import nn

from core.config import Config, ConfigError, NetConfig
from core.envs.spec import EnvSpec
from core.experiments.spec import ExperimentError
from core.modelfree.networks import Encoder

try:  # the base class of the extractor; a stand-in keeps this module importable without SB3
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor as _FeaturesBase
except ImportError:  # pragma: no cover - exercised only where the bench extra is absent

    class _FeaturesBase(nn.Module):  # type: ignore[no-redef]
        def __init__(self, observation_space: Any, features_dim: int = 0) -> None:
            require_sb3("sb3-sac")


SB3_ALGOS: dict[str, str] = {"sb3-sac": "sac", "sb3-td3": "td3", "sb3-ddpg": "ddpg", "sb3-sac-pink": "sac"}
"""Experiment-runner algo name → SB3 algorithm (``train_sb3``'s ``algo``)."""

PINK_PEERS: frozenset[str] = frozenset({"sb3-sac-pink"})
"""The peers whose actor samples through ``pink-noise-rl``'s ``PinkNoiseDist`` (:func:`use_pink_noise`)."""

PINK_NOTE = (
    "pink.PinkNoiseDist(seq_len, action_dim, rng=numpy.random.default_rng(run.seed)) as the SAC actor's "
    "action_dist, seq_len = the env's step limit (pink-noise-rl's example); the only difference from sb3-sac"
)

NON_DEFAULTS: dict[str, str] = {
    "learning_starts": "config.agent.learning_starts (ours: 500; SB3: 100) — the same warm-up budget",
    "buffer_size": "config.agent.buffer_size (ours: 100_000; SB3: 1_000_000) — the same memory",
    "batch_size": "config.agent.batch_size (ours: 64; SB3: 256) — the same minibatch per update",
    "gamma": "config.agent.gamma (0.99 in both) — the discount is part of the task's objective",
    "policy_kwargs.features_extractor_class (images)": "DualsysEncoderExtractor (NatureCNN needs >= 36 px "
    "images); vector observations keep MlpPolicy's FlattenExtractor",
    "action_noise (td3, ddpg)": "NormalActionNoise(0, 0.1) — SB3's TD3 and DDPG have none by default; "
    "the TD3 paper's value",
    "seed": "config.run.seed",
    "device": "config.run.device",
}
"""Every setting of ``agent.sb3_hyperparams=dualsys`` that differs from SB3's defaults, and why (also in
docs/model-free.md). The ``zoo`` setting is the zoo's entry instead (recorded in sb3_hyperparams.json)."""

TD3_NOISE_STD = 0.1
"""Std of the Gaussian exploration noise of TD3 and DDPG (Fujimoto et al. 2018; RL Zoo's usual value)."""

RECORDED_ATTRIBUTES: tuple[str, ...] = (
    "learning_rate",
    "buffer_size",
    "learning_starts",
    "batch_size",
    "tau",
    "gamma",
    "train_freq",
    "gradient_steps",
    "n_steps",
    "action_noise",
    "optimize_memory_usage",
    "use_sde",
    "sde_sample_freq",
    "use_sde_at_warmup",
    "ent_coef",
    "target_entropy",
    "target_update_interval",
    "policy_delay",
    "target_policy_noise",
    "target_noise_clip",
    "policy_kwargs",
)
"""The SB3 model attributes :func:`hyperparams_record` reports (those the algorithm has)."""


def missing_sb3_message(name: str) -> str:
    return f"{name} needs Stable-Baselines3: pip install 'dualsys[bench]'"


def require_sb3(name: str = "sb3-sac") -> None:
    """Raise the one-line ExperimentError (exit 2 in the CLI) when Stable-Baselines3 is not installed."""
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        raise ExperimentError(missing_sb3_message(name)) from None


# -- the features extractor of images -----------------------------------------------------------


class DualsysEncoderExtractor(_FeaturesBase):
    """SB3 features extractor = :class:`modelfree.networks.Encoder` (our f_ω), so SAC/TD3/DDPG see pixels
    through the same convolutional shape as our agents and the comparison isolates the algorithm.

    ``observation_space``: SB3's channels-first image space ``(3, H, W)`` (after ``VecTransposeImage``).
    ``forward`` takes what SB3's ``preprocess_obs`` makes of it: float ``[N, 3, H, W]`` already divided by
    255 (``normalize_images=True``, SB3's default) — the input of ``Encoder.forward``; no second scaling.
    Output: the latent φ, ``[N, latent_dim]`` (ReLU), ``features_dim = latent_dim``.
    """

    def __init__(
        self,
        observation_space: Any,
        arch: str = "strided",
        conv_channels: tuple[int, ...] | list[int] = (16, 32, 32),
        latent_dim: int = 32,
    ) -> None:
        shape = tuple(int(n) for n in observation_space.shape)
        if len(shape) != 3 or shape[0] not in (1, 3, 4):
            raise ValueError(f"DualsysEncoderExtractor needs a channels-first image space, got {shape}")
        super().__init__(observation_space, features_dim=int(latent_dim))
        net = NetConfig(arch=arch, conv_channels=tuple(int(c) for c in conv_channels), latent_dim=latent_dim)  # type: ignore[arg-type]
        channels, height, width = shape
        self.encoder = Encoder(net, obs_shape=(height, width, channels))

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        return self.encoder(observations)


def extractor_kwargs(net: NetConfig) -> dict[str, Any]:
    return {"arch": net.arch, "conv_channels": list(net.conv_channels), "latent_dim": net.latent_dim}


# -- the settings -------------------------------------------------------------------------------


@dataclass
class SB3Settings:
    """The policy and constructor arguments of one run, and where they came from."""

    name: str
    """``dualsys`` or ``zoo`` (``agent.sb3_hyperparams``)."""
    policy: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    """Constructor keyword arguments (SB3 objects), without ``seed``/``device``."""
    source: str = ""
    zoo_entry: dict[str, Any] | None = None
    unused: dict[str, Any] = field(default_factory=dict)
    given: Any = None
    """``kwargs`` as plain JSON, taken before SB3 sees them (SB3 adds keys to ``policy_kwargs``)."""

    @property
    def schedules_learning_rate(self) -> bool:
        return callable(self.kwargs.get("learning_rate"))


def sb3_settings(config: Config, algo: str, spec: EnvSpec) -> SB3Settings:
    """The settings ``config.agent.sb3_hyperparams`` names for SB3 ``algo`` on an env of ``spec``."""
    if config.agent.sb3_hyperparams == "zoo":
        from core.experiments.sb3_zoo import zoo_settings

        zoo = zoo_settings(algo, config.env.id, action_dim=spec.action_dim, obs_kind=spec.obs_kind)
        settings = SB3Settings(
            name="zoo",
            policy=zoo.policy,
            kwargs=zoo.kwargs,
            source=zoo.source,
            zoo_entry=zoo.entry,
            unused=zoo.unused,
        )
    else:
        settings = _dualsys_settings(config, algo, spec)
    settings.given = describe(settings.kwargs)
    if settings.schedules_learning_rate and config.run.steps is None:
        raise ConfigError(
            f"{settings.source}: a learning-rate schedule runs over run.steps; this run has no step budget"
        )
    return settings


def _dualsys_settings(config: Config, algo: str, spec: EnvSpec) -> SB3Settings:
    agent = config.agent
    kwargs: dict[str, Any] = {
        "learning_starts": agent.learning_starts,
        "buffer_size": agent.buffer_size,
        "batch_size": agent.batch_size,
        "gamma": agent.gamma,
    }
    if algo in ("td3", "ddpg"):
        from stable_baselines3.common.noise import NormalActionNoise

        dim = spec.action_dim
        kwargs["action_noise"] = NormalActionNoise(mean=np.zeros(dim), sigma=TD3_NOISE_STD * np.ones(dim))
    if spec.obs_kind == "image":
        kwargs["policy_kwargs"] = {
            "features_extractor_class": DualsysEncoderExtractor,
            "features_extractor_kwargs": extractor_kwargs(config.net),
        }
        policy = "CnnPolicy"
    else:
        policy = "MlpPolicy"
    return SB3Settings(
        name="dualsys",
        policy=policy,
        kwargs=kwargs,
        source="SB3's defaults but NON_DEFAULTS (core/experiments/sb3_settings.py)",
    )


def use_pink_noise(model: Any, seq_len: int, seed: int) -> Any:
    """Give SB3 SAC ``model`` the package's pink-noise distribution, as its example does:
    ``model.actor.action_dist = PinkNoiseDist(seq_len, action_dim)`` (2.0.1's argument order), with a
    generator seeded by ``seed`` so that a run is reproducible. Returns the distribution."""
    from pink import PinkNoiseDist

    if getattr(model, "use_sde", False):
        raise ConfigError("sb3-sac-pink replaces SAC's squashed Gaussian; this setting uses gSDE (use_sde)")
    action_dim = int(model.action_space.shape[-1])
    model.actor.action_dist = PinkNoiseDist(int(seq_len), action_dim, rng=np.random.default_rng(seed))
    return model.actor.action_dist


def algorithm_class(algo: str) -> Any:
    """SB3's ``SAC``, ``TD3`` or ``DDPG``."""
    import stable_baselines3

    if algo not in SB3_ALGOS.values():
        raise ConfigError(f"unknown SB3 algorithm {algo!r} (choose from {', '.join(SB3_ALGOS.values())})")
    return getattr(stable_baselines3, algo.upper())


def make_model(settings: SB3Settings, algo: str, venv: Any, *, seed: int, device: str) -> Any:
    """A new SB3 model of ``algo`` on ``venv`` with ``settings``."""
    return algorithm_class(algo)(
        settings.policy, venv, seed=seed, device=device, verbose=0, **settings.kwargs
    )


# -- the record ---------------------------------------------------------------------------------


def describe(value: Any) -> Any:
    """``value`` as plain JSON: SB3's schedules, action noises and train frequencies by their parameters,
    classes by their import path, arrays as lists."""
    from stable_baselines3.common import noise, utils
    from stable_baselines3.common.type_aliases import TrainFreq

    if isinstance(value, bool | str) or value is None:
        return value
    if isinstance(value, int | float | np.integer | np.floating):
        return value.item() if isinstance(value, np.generic) else value
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, TrainFreq):
        return [int(value.frequency), value.unit.value]
    if isinstance(value, tuple | list):
        return [describe(item) for item in value]
    if isinstance(value, dict):
        return {str(key): describe(item) for key, item in value.items()}
    if isinstance(value, type):
        return f"{value.__module__}.{value.__qualname__}"
    if isinstance(value, utils.FloatSchedule):
        return describe(value.value_schedule)
    if isinstance(value, utils.ConstantSchedule):
        return float(value.val)
    if isinstance(value, utils.LinearSchedule):
        return {
            "schedule": "linear",
            "start": value.start,
            "end": value.end,
            "end_fraction": value.end_fraction,
            "over": "run.steps (SB3's progress_remaining = 1 - num_timesteps / run.steps)",
        }
    if isinstance(value, noise.OrnsteinUhlenbeckActionNoise):
        return {
            "class": type(value).__name__,
            "mean": value._mu.tolist(),
            "sigma": value._sigma.tolist(),
            "theta": value._theta,
            "dt": value._dt,
        }
    if isinstance(value, noise.NormalActionNoise):
        return {"class": type(value).__name__, "mean": value._mu.tolist(), "sigma": value._sigma.tolist()}
    return repr(value)


def hyperparams_record(settings: SB3Settings, algo: str, model: Any, config: Config) -> dict[str, Any]:
    """The content of ``sb3_hyperparams.json``: the setting and its source, the arguments it gave, and the
    values the built ``model`` uses (SB3's defaults filled in), with the networks' layer sizes."""
    import stable_baselines3

    used = {name: describe(getattr(model, name)) for name in RECORDED_ATTRIBUTES if hasattr(model, name)}
    nets = {
        part: describe(getattr(getattr(model, part, None), "net_arch", None))
        for part in ("actor", "critic")
        if getattr(getattr(model, part, None), "net_arch", None) is not None
    }
    record: dict[str, Any] = {
        "algo": f"sb3-{algo}",
        "env": config.env.id,
        "setting": settings.name,
        "source": settings.source,
        "stable_baselines3": str(stable_baselines3.__version__),
        "policy": settings.policy,
        "given": settings.given if settings.given is not None else describe(settings.kwargs),
        "used": used,
        "net_arch": nets,
    }
    dist = getattr(getattr(model, "actor", None), "action_dist", None)
    if type(dist).__name__ == "PinkNoiseDist":
        record["algo"] = "sb3-sac-pink"
        record["action_dist"] = {
            "class": f"{type(dist).__module__}.{type(dist).__qualname__}",
            "seq_len": int(dist.gen.time_steps),
            "action_dim": int(dist.action_dim),
            "note": PINK_NOTE,
        }
    if settings.zoo_entry is not None:
        record["zoo_entry"] = describe(settings.zoo_entry)
        record["zoo_unused"] = {key: describe(value) for key, value in settings.unused.items()}
    else:
        record["non_defaults"] = dict(NON_DEFAULTS)
    return record
