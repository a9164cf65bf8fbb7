"""A modern peer: Stable-Baselines3 SAC and TD3 from pixels, as methods of the experiment runner.

``train_sb3(config, run_dir, algo="sac"|"td3", resume=..., on_episode=..., should_stop=...) -> summary``
has the contract of :func:`core.runs.trainer.train`: the same training and evaluation envs
(:func:`core.runs.trainer.make_env`), the same budget (``run.steps`` / ``run.episodes`` / ``run.max_wall_s``,
checked at episode boundaries), the same first reset (``env.reset(seed=run.seed)``, then the env's own
generator), greedy evaluations every ``run.eval_every`` training episodes with
:func:`core.runs.trainer.evaluate` (seeds ``EVAL_SEED + k``) and once at the end, and a run directory with the
same files, metrics.csv keys and summary.json keys (AuC and Final Perf from :mod:`core.runs.metrics`), so
``dualsys experiment report`` reads an SB3 cell like any other.

The networks: SB3's ``CnnPolicy`` with its default heads (``net_arch=[256, 256]``, separate feature
extractors for actor and critic) on :class:`DualsysEncoderExtractor`, our encoder f_ω of
:mod:`modelfree.networks` built from ``config.net`` (the default profile: stride-2 3×3 convolutions
16→32→32, a dense layer to the 32-d latent, ReLU). SB3's default NatureCNN needs images of at least 36 px on
each side; ours are 32×64. SB3 moves images to channels-first (``VecTransposeImage``) and divides by 255 once
(``normalize_images=True``); the extractor receives float ``[N, 3, 32, 64]`` in [0, 1], the input
:class:`core.modelfree.networks.Encoder` expects, and does not scale again.

SB3's defaults everywhere except (docs/model-free.md, "A modern peer"): ``learning_starts``,
``buffer_size``, ``batch_size`` and ``gamma`` from ``config.agent`` (the same budget of warm-up, memory,
minibatch and discount as our agents), and for TD3 Gaussian action noise N(0, 0.1²) (SB3's TD3 has no
exploration noise by default; 0.1 is the TD3 paper's value). See :data:`NON_DEFAULTS`.

Checkpoints (``checkpoints/``), written at episode boundaries after that step's gradient update, every
``run.checkpoint_every`` episodes / ``run.checkpoint_every_s`` seconds and when the run ends or stops:

* ``sb3-model-<step>.zip`` — ``model.save`` (weights, optimisers, entropy coefficient, counters);
* ``sb3-replay-<step>.pt`` — the replay buffer's filled part (``torch.save`` of uint8 arrays). Not
  ``save_replay_buffer``: it pickles the whole preallocated capacity (1.2 GB at 100k transitions of
  3×32×64 obs and next obs) however little is filled;
* ``latest.pt`` — a dualsys checkpoint (``core.runs.run_dir.load_checkpoint``) naming those two files, with
  the counters, the evaluation history and every generator (torch, NumPy, Python, the action space's,
  the training env's), written last; older SB3 files are removed after it. Every write is atomic, so
  ``latest.pt`` always names a complete, consistent pair;
* ``best.zip`` — ``model.save`` at the best greedy evaluation (success rate, then return).

Stopping and resume follow the trainer: ``should_stop()`` (or Ctrl-C) is polled every step; the run
stops after that step's update, abandoning the episode; ``resume=True`` restores the model, the replay
buffer and every generator, drops metrics.csv rows after the checkpoint and continues with the budget of
the ``config`` passed in (its ``net``, ``env``, ``agent`` and ``dual`` sections and ``run.algo`` must
match). An uninterrupted run and a stopped-and-resumed one of the same seed give the same episodes.

Stable-Baselines3 is optional (the ``bench`` extra); this module imports it only when a run starts, and
a missing SB3 is the one-line :class:`core.experiments.spec.ExperimentError` of :func:`require_sb3`.
``core.experiments.dispatch`` sends the cells of ``sb3-sac`` and ``sb3-td3`` to :class:`SB3Runner`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import io
import json
import random
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from core.config import Config, ConfigError, NetConfig
from core.experiments.runners import (
    ConfigCellRunner,
    EpisodeCallback,
    cell_overrides,
)
from core.experiments.spec import ExperimentError, ExperimentSpec, MethodSpec
from core.modelfree.agent import generator_state, restore_generator
from core.modelfree.networks import Encoder
from core.runs.bookkeeping import RunBookkeeping, mean_dicts
from core.runs.run_dir import RunDirectoryError, atomic_torch_save, atomic_write_bytes

try:  # the base class of the extractor; a stand-in keeps this module importable without SB3
    from stable_baselines3.common.torch_layers import BaseFeaturesExtractor as _FeaturesBase
except ImportError:  # pragma: no cover - exercised only where the bench extra is absent

    class _FeaturesBase(nn.Module):  # type: ignore[no-redef]
        def __init__(self, observation_space: Any, features_dim: int = 0) -> None:
            require_sb3("sb3-sac")


SB3_ALGOS: dict[str, str] = {"sb3-sac": "sac", "sb3-td3": "td3"}
"""Experiment-runner algo name → SB3 algorithm (``train_sb3``'s ``algo``)."""

NON_DEFAULTS: dict[str, str] = {
    "learning_starts": "config.agent.learning_starts (ours: 500; SB3: 100) — the same warm-up budget",
    "buffer_size": "config.agent.buffer_size (ours: 100_000; SB3: 1_000_000) — the same memory",
    "batch_size": "config.agent.batch_size (ours: 64; SB3: 256) — the same minibatch per update",
    "gamma": "config.agent.gamma (0.99 in both) — the discount is part of the task's objective",
    "policy_kwargs.features_extractor_class": "DualsysEncoderExtractor (NatureCNN needs >= 36 px images)",
    "action_noise (td3)": "NormalActionNoise(0, 0.1) — SB3's TD3 has none by default; TD3 paper's value",
    "seed": "config.run.seed",
    "device": "config.run.device",
}
"""Every setting that differs from SB3's defaults, and why (also in docs/model-free.md)."""

TD3_NOISE_STD = 0.1
"""Std of TD3's Gaussian exploration noise (Fujimoto et al. 2018; RL Zoo's usual value)."""

_SB3_FORMAT = "dualsys-sb3/1"


def missing_sb3_message(name: str) -> str:
    return f"{name} needs Stable-Baselines3: pip install 'dualsys[bench]'"


def require_sb3(name: str = "sb3-sac") -> None:
    """Raise the one-line ExperimentError (exit 2 in the CLI) when Stable-Baselines3 is not installed."""
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        raise ExperimentError(missing_sb3_message(name)) from None


# -- the features extractor ---------------------------------------------------------------------


class DualsysEncoderExtractor(_FeaturesBase):
    """SB3 features extractor = :class:`modelfree.networks.Encoder` (our f_ω), so SAC/TD3 see pixels through
    the same convolutional shape as our agents and the comparison isolates the algorithm.

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


# -- env wrapper, greedy adapter ----------------------------------------------------------------


def _env_rng_state(env: Any) -> dict[str, Any]:
    from core.runs.trainer import _env_rng_state as state

    return state(env)


def _make_reset_recorder(env: Any) -> Any:
    """The training env, remembering its generator just before each reset (a checkpoint at an episode
    boundary is written after SB3's automatic reset; resuming replays that reset from this state)."""
    import gymnasium as gym

    class ResetRecorder(gym.Wrapper):
        def __init__(self, inner: Any) -> None:
            super().__init__(inner)
            self.before_reset: dict[str, Any] = _env_rng_state(inner)

        def reset(self, **kwargs: Any) -> Any:
            self.before_reset = _env_rng_state(self.env)
            return self.env.reset(**kwargs)

    return ResetRecorder(env)


class GreedyPolicy:
    """``core.runs.trainer.evaluate``'s agent interface over an SB3 model: the deterministic action."""

    def __init__(self, model: Any) -> None:
        self.model = model

    def act(self, obs: np.ndarray, explore: bool = False) -> tuple[np.ndarray, dict[str, float]]:
        action, _ = self.model.predict(obs, deterministic=not explore)
        return np.asarray(action, dtype=np.float32), {}


# -- the run ------------------------------------------------------------------------------------


class _EndOfRun(Exception):
    """Raised from the callback at a rollout start (after the last step's update) to leave ``learn``."""


def _model_bytes(model: Any) -> bytes:
    buffer = io.BytesIO()
    model.save(buffer)
    return buffer.getvalue()


_REPLAY_ARRAYS = ("observations", "next_observations", "actions", "rewards", "dones", "timeouts")


def _replay_state(buffer: Any) -> dict[str, Any]:
    filled = buffer.buffer_size if buffer.full else buffer.pos
    state: dict[str, Any] = {
        "pos": int(buffer.pos),
        "full": bool(buffer.full),
        "size": int(buffer.buffer_size),
    }
    for name in _REPLAY_ARRAYS:
        array = getattr(buffer, name, None)
        if array is not None:
            state[name] = torch.from_numpy(np.ascontiguousarray(array[:filled]))
    return state


def _load_replay_state(buffer: Any, state: Mapping[str, Any]) -> None:
    if int(state["size"]) != buffer.buffer_size:
        raise RunDirectoryError(
            f"the saved replay buffer holds {state['size']} transitions, "
            f"the config gives {buffer.buffer_size}"
        )
    for name in _REPLAY_ARRAYS:
        if name in state:
            data = state[name].numpy()
            getattr(buffer, name)[: len(data)] = data
    buffer.pos = int(state["pos"])
    buffer.full = bool(state["full"])


class _SB3Run(RunBookkeeping):
    """State of one ``train_sb3`` call (the bookkeeping of ``core.runs.trainer._Trainer``, SB3's training)."""

    def __init__(
        self,
        config: Config,
        run_dir: Path,
        algo: str,
        resume: bool,
        on_episode: EpisodeCallback | None,
        should_stop: Callable[[], bool] | None,
        command: str | None,
    ) -> None:
        if algo not in SB3_ALGOS.values():
            raise ConfigError(f"unknown SB3 algorithm {algo!r} (choose from sac, td3)")
        self.algo = algo
        self.name = f"sb3-{algo}"
        require_sb3(self.name)
        if config.run.algo != self.name:
            config = dataclasses.replace(config, run=dataclasses.replace(config.run, algo=self.name))
        super().__init__(config, run_dir, resume, on_episode, should_stop, command)

    # -- setup ----------------------------------------------------------------------------------
    def _check_checkpoint(self, checkpoint: Mapping[str, Any]) -> None:
        if checkpoint.get("sb3", {}).get("format") != _SB3_FORMAT:
            raise RunDirectoryError(f"{self.dir.latest_path} is not a Stable-Baselines3 run's checkpoint")

    def _algorithm_class(self) -> Any:
        from stable_baselines3 import SAC, TD3

        return SAC if self.algo == "sac" else TD3

    def _hyperparameters(self, action_dim: int) -> dict[str, Any]:
        agent = self.config.agent
        kwargs: dict[str, Any] = {
            "learning_starts": agent.learning_starts,
            "buffer_size": agent.buffer_size,
            "batch_size": agent.batch_size,
            "gamma": agent.gamma,
        }
        if self.algo == "td3":
            from stable_baselines3.common.noise import NormalActionNoise

            kwargs["action_noise"] = NormalActionNoise(
                mean=np.zeros(action_dim), sigma=TD3_NOISE_STD * np.ones(action_dim)
            )
        return kwargs

    def _build(self, venv: Any, checkpoint: dict[str, Any] | None) -> Any:
        cls = self._algorithm_class()
        action_dim = int(venv.action_space.shape[0])
        kwargs = self._hyperparameters(action_dim)
        if checkpoint is None:
            return cls(
                "CnnPolicy",
                venv,
                policy_kwargs={
                    "features_extractor_class": DualsysEncoderExtractor,
                    "features_extractor_kwargs": extractor_kwargs(self.config.net),
                },
                seed=self.config.run.seed,
                device=self.config.run.device,
                verbose=0,
                **kwargs,
            )
        sb3 = checkpoint["sb3"]
        extra = {"action_noise": kwargs["action_noise"]} if "action_noise" in kwargs else {}
        model = cls.load(
            self.dir.checkpoints / sb3["model"], env=venv, device=self.config.run.device, **extra
        )
        replay = torch.load(self.dir.checkpoints / sb3["replay"], map_location="cpu", weights_only=True)
        _load_replay_state(model.replay_buffer, replay)
        # learn() resets the env as the trainer's resume does: from the restored generator, with no seed
        # (load() re-seeds the VecEnv with the run's seed for its next reset; drop that)
        model._last_obs = None
        venv._reset_seeds()
        return model

    def _restore(self, checkpoint: dict[str, Any], model: Any, env: Any) -> None:
        from core.runs.trainer import _restore_env_rng

        if int(model.num_timesteps) != int(checkpoint["counters"]["global_step"]):
            raise RunDirectoryError(f"{self.dir.latest_path}: the SB3 model and the counters disagree")
        rngs = checkpoint["rng"]
        torch.set_rng_state(rngs["torch"])
        numpy_state = json.loads(rngs["numpy"])
        np.random.set_state(
            (numpy_state[0], np.asarray(numpy_state[1], dtype=np.uint32), *numpy_state[2:])  # type: ignore[arg-type]
        )
        python_state = json.loads(rngs["python"])
        random.setstate((python_state[0], tuple(python_state[1]), python_state[2]))
        restore_generator(model.action_space.np_random, rngs["action_space"])
        _restore_env_rng(env, checkpoint["env_rng"])
        self._restore_progress(checkpoint)

    # -- checkpoints ----------------------------------------------------------------------------
    def _save_latest(self, model: Any, env_rng: dict[str, Any], wall_s: float) -> None:
        checkpoints = self.dir.checkpoints
        model_name = f"sb3-model-{self.global_step}.zip"
        replay_name = f"sb3-replay-{self.global_step}.pt"
        atomic_write_bytes(checkpoints / model_name, _model_bytes(model))
        atomic_torch_save(_replay_state(model.replay_buffer), checkpoints / replay_name)
        numpy_state = np.random.get_state()
        python_state = random.getstate()
        atomic_torch_save(
            {
                **self._checkpoint_head(wall_s),
                "evals": self._eval_history(),
                "sb3": {
                    "format": _SB3_FORMAT,
                    "algo": self.algo,
                    "model": model_name,
                    "replay": replay_name,
                    "version": _sb3_version(),
                },
                "rng": {
                    "torch": torch.get_rng_state(),
                    "numpy": json.dumps(
                        [numpy_state[0], numpy_state[1].tolist(), *(float(x) for x in numpy_state[2:])]
                    ),
                    "python": json.dumps([python_state[0], list(python_state[1]), python_state[2]]),
                    "action_space": generator_state(model.action_space.np_random),
                },
                "env_rng": env_rng,
            },
            self.dir.latest_path,
        )
        for path in checkpoints.glob("sb3-*"):
            if path.name not in (model_name, replay_name):
                path.unlink(missing_ok=True)

    def _evaluate(self, model: Any, eval_env: Any) -> dict[str, float]:
        from core.runs.trainer import evaluate

        result = evaluate(GreedyPolicy(model), eval_env, self.config.run.eval_episodes)  # type: ignore[arg-type]
        if self._record_evaluation(result):
            atomic_write_bytes(self.dir.checkpoints / "best.zip", _model_bytes(model))
        return result

    # -- the loop -------------------------------------------------------------------------------
    def run(self) -> dict[str, Any]:
        from stable_baselines3.common.vec_env import DummyVecEnv

        from core.runs.trainer import make_env

        checkpoint = self._begin()
        cfg = self.config
        env = make_env(cfg).env
        recorder = _make_reset_recorder(env)
        venv = DummyVecEnv([lambda: recorder])
        self.eval_env: Any = None
        try:
            model = self._build(venv, checkpoint)
            if checkpoint is not None:
                self._restore(checkpoint, model, env)
            self._start_clock()
            callback = self._callback(model, recorder, env)
            with self.stop_flag:
                with contextlib.suppress(_EndOfRun):  # the callback ends the run at an episode boundary
                    model.learn(
                        total_timesteps=10**12,
                        callback=callback,
                        reset_num_timesteps=checkpoint is None,
                        log_interval=None,  # type: ignore[arg-type]
                    )
                final_eval: dict[str, float] = {}
                if self._final_evaluation_due():
                    self.eval_env = self.eval_env or make_env(cfg, evaluation=True).env
                    final_eval = self._evaluate(model, self.eval_env)
            # at an episode boundary the env was already reset for the next episode: resume replays it
            env_rng = recorder.before_reset if callback.at_boundary else _env_rng_state(env)
            self._save_latest(model, env_rng, self.wall())
            return self._finish(final_eval, ac=None)
        finally:
            venv.close()
            if self.eval_env is not None:
                self.eval_env.close()

    def _callback(self, model: Any, recorder: Any, env: Any) -> Any:
        from stable_baselines3.common.callbacks import BaseCallback

        from core.runs.trainer import make_env

        run = self

        class EpisodeRecords(BaseCallback):
            """Per step: sum the episode, poll the stop flag. At the next rollout start (after that
            step's gradient update): the episode record, evaluation, checkpoint, budget and stop."""

            def __init__(self) -> None:
                super().__init__(verbose=0)
                self.episode_return = 0.0
                self.length = 0
                self.finished: dict[str, Any] | None = None
                self.losses: list[dict[str, float]] = []
                self.n_updates = int(model._n_updates)
                self.at_boundary = True

            def _on_step(self) -> bool:
                run.global_step += 1
                self.length += 1
                self.episode_return += float(self.locals["rewards"][0])
                self.at_boundary = False
                if bool(self.locals["dones"][0]):
                    info = self.locals["infos"][0]
                    self.finished = {
                        "return": self.episode_return,
                        "length": self.length,
                        "success": bool(info.get("success", False)),
                        "toppled": bool(info.get("toppled", False)),
                    }
                    self.episode_return, self.length = 0.0, 0
                    self.at_boundary = True
                if run.stop_flag():
                    run.stopped = True
                return True

            def _collect_losses(self) -> None:
                if int(model._n_updates) == self.n_updates:
                    return
                self.n_updates = int(model._n_updates)
                logged = model.logger.name_to_value
                losses = {
                    "losses/critic": logged.get("train/critic_loss"),
                    "losses/actor": logged.get("train/actor_loss"),
                }
                if run.algo == "sac":
                    losses["sb3/ent_coef"] = logged.get("train/ent_coef")
                self.losses.append({k: float(v) for k, v in losses.items() if v is not None})

            def _on_rollout_start(self) -> None:
                self._collect_losses()
                if self.finished is not None:
                    self._end_episode(self.finished)
                    self.finished = None
                if run.stopped or run.stop_flag():
                    run.stopped = True
                    raise _EndOfRun
                if self.at_boundary and run._budget_spent():
                    raise _EndOfRun

            def _end_episode(self, finished: dict[str, Any]) -> None:
                record = run._new_record(
                    finished["return"], finished["length"], finished["success"], finished["toppled"]
                )
                record.update(mean_dicts(self.losses))
                self.losses = []
                if run._evaluation_due():
                    run.eval_env = run.eval_env or make_env(run.config, evaluation=True).env
                    record.update(run._evaluate(model, run.eval_env))
                run._log_episode(record)
                if run._checkpoint_due():
                    run._save_latest(model, recorder.before_reset, run.wall())
                    run.last_checkpoint = time.perf_counter()

        return EpisodeRecords()


def _sb3_version() -> str:
    import stable_baselines3

    return str(stable_baselines3.__version__)


def train_sb3(
    config: Config,
    run_dir: Path | str,
    *,
    algo: str = "sac",
    resume: bool = False,
    on_episode: EpisodeCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
    command: str | None = None,
) -> dict[str, Any]:
    """Train SB3 ``algo`` (``sac`` or ``td3``) into ``run_dir`` (or continue it); returns the summary.

    Same contract as :func:`core.runs.trainer.train` (see the module docstring); ``config.run.algo`` is set to
    ``sb3-<algo>``. Raises ExperimentError (one line) when Stable-Baselines3 is not installed.
    """
    return _SB3Run(config, Path(run_dir), algo, resume, on_episode, should_stop, command).run()


# -- the experiment runner's cell runner ------------------------------------------------------


class SB3Runner(ConfigCellRunner):
    """Cells of ``sb3-sac`` / ``sb3-td3``: ``core.config`` (profile → overrides → the cell's keys, as for
    every method) + :func:`train_sb3`. ``run.algo`` is the SB3 name (not in ``core.runs.methods``)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.algo = SB3_ALGOS[name]

    def resolve(self, spec: ExperimentSpec, method: MethodSpec, reward: str, seed: int) -> dict[str, Any]:
        from core.config import load_config

        require_sb3(self.name)
        if method.ac is not None:
            raise ExperimentError(
                f"bad value for ac: method {method.label!r} ({self.name}) has no actor-update rule of ours"
            )
        items = cell_overrides(spec, method, reward, seed, algo=self.name)
        return self._checked_config(method, reward, lambda: load_config(spec.profile, items))

    def training_function(self) -> Callable[..., dict[str, Any]]:
        return functools.partial(train_sb3, algo=self.algo)


