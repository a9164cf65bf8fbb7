"""A modern peer: Stable-Baselines3 SAC, TD3 and DDPG on any task, as methods of the experiment runner.

``train_sb3(config, run_dir, algo="sac"|"td3"|"ddpg", resume=..., on_episode=..., should_stop=...)``
(the summary) has the contract of :func:`core.runs.trainer.train`: the same training and evaluation envs
(:func:`core.runs.trainer.make_env`, actions rescaled to [-1, 1]), the same budget (``run.steps`` /
``run.episodes`` / ``run.max_wall_s``, checked at episode boundaries), the same first reset
(``env.reset(seed=run.seed)``, then the env's own generator), greedy evaluations every ``run.eval_every``
training episodes with :func:`core.runs.trainer.evaluate` (seeds ``EVAL_SEED + k``, success by
``env.success``) and once at the end, and a run directory with the same files, metrics.csv keys and
summary.json keys (AuC and Final Perf from :mod:`core.runs.metrics`), so ``dualsys experiment report``
reads an SB3 cell like any other. The policy and the hyperparameters come from
:mod:`core.experiments.sb3_settings` (``agent.sb3_hyperparams``: ``dualsys`` — SB3's defaults on our
budget, images through our encoder — or ``zoo``, RL Baselines3 Zoo's entry for the task); the run writes
what it used to ``sb3_hyperparams.json``.

Episodes and SB3's rollouts. SB3 collects ``train_freq`` steps (a "rollout"), then makes
``gradient_steps`` updates. An episode that ends on a rollout's last step is closed (record, evaluation,
checkpoint, budget, stop) after that update, at the next rollout start — with ``train_freq=1`` (the
``dualsys`` setting) that is every episode. An episode that ends inside a rollout (the zoo's SAC on
MountainCarContinuous-v0 collects 32 steps per update) is closed at its last step: when a checkpoint, a
stop or the end of the budget falls there, the callback stores that step's transition as SB3 would
(``_store_transition``, the episode count, the action-noise reset) and leaves ``learn``; the checkpoint
records how far the rollout had got, and ``learn`` is entered again (in the same process, or on resume)
with a first rollout of the remaining steps, so the update falls on the same env step as in an
uninterrupted run. Either kind of checkpoint also holds the gSDE exploration matrices and the torch
generator, restored at the next rollout start (SB3 resamples gSDE noise there). ``sde_sample_freq > 0``
with a multi-step ``train_freq`` is the one case where a mid-rollout checkpoint shifts when gSDE noise is
resampled next (no zoo entry the peers can run has both).

Checkpoints (``checkpoints/``), at episode boundaries, every ``run.checkpoint_every`` episodes /
``run.checkpoint_every_s`` seconds and when the run ends or stops:

* ``sb3-model-<step>.zip`` — ``model.save`` (weights, optimisers, entropy coefficient, counters);
* ``sb3-replay-<step>.pt`` — the replay buffer's filled part (``torch.save`` of its arrays). Not
  ``save_replay_buffer``: it pickles the whole preallocated capacity (1.2 GB at 100k transitions of
  3×32×64 obs and next obs) however little is filled;
* ``latest.pt`` — a dualsys checkpoint (``core.runs.run_dir.load_checkpoint``) naming those two files, with
  the counters, the evaluation history, the rollout's progress, the gSDE matrices and every generator
  (torch, NumPy, Python, the action space's, the training env's), written last; older SB3 files are
  removed after it. Every write is atomic, so ``latest.pt`` always names a complete, consistent pair;
* ``best.zip`` — ``model.save`` at the best greedy evaluation (success rate, then return).

Stopping and resume follow the trainer: ``should_stop()`` (or Ctrl-C) is polled every step; the run
stops at the end of the current rollout (at once when an episode ends inside it), abandoning the
episode; ``resume=True`` restores the model, the replay buffer and every generator, drops metrics.csv rows
after the checkpoint and continues with the budget of the ``config`` passed in (its ``net``, ``env``,
``agent`` and ``dual`` sections and ``run.algo`` must match). An uninterrupted run and one stopped at an
episode's end and resumed, of the same seed, give the same episodes.

Stable-Baselines3 is optional (the ``bench`` extra); this module imports it only when a run starts, and
a missing SB3 is the one-line :class:`core.experiments.spec.ExperimentError` of
:func:`core.experiments.sb3_settings.require_sb3`. ``core.experiments.dispatch`` sends the cells of
``sb3-sac``, ``sb3-td3``, ``sb3-ddpg`` and ``sb3-sac-pink`` to :class:`SB3Runner`.

``sb3-sac-pink`` (``train_sb3(..., pink=True)``) is SB3's SAC with ``pink-noise-rl``'s ``PinkNoiseDist`` as
the actor's distribution (:func:`core.experiments.sb3_settings.use_pink_noise`), set on the built or loaded
model; its checkpoints add the pink process's sequence, position and generator, so a resumed run goes on
with the same noise.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import io
import json
import math
import random
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import Config, ConfigError
from core.envs.gym_env import episode_success
from core.experiments.runners import (
    ConfigCellRunner,
    EpisodeCallback,
    cell_overrides,
)
from core.experiments.sb3_settings import (
    PINK_PEERS,
    SB3_ALGOS,
    SB3Settings,
    algorithm_class,
    hyperparams_record,
    make_model,
    require_sb3,
    sb3_settings,
    use_pink_noise,
)
from core.experiments.spec import ExperimentError, ExperimentSpec, MethodSpec
from core.modelfree.agent import generator_state, restore_generator
from core.modelfree.noise import DEFAULT_SEQ_LEN, episode_limit
from core.runs.bookkeeping import RunBookkeeping, env_diagnostics, mean_dicts
from core.runs.run_dir import RunDirectoryError, atomic_torch_save, atomic_write_bytes, atomic_write_text

_SB3_FORMAT = "dualsys-sb3/1"

HYPERPARAMS_FILE = "sb3_hyperparams.json"
"""The run directory's record of the SB3 settings used (:func:`sb3_settings.hyperparams_record`)."""


# -- env wrapper, greedy adapter ----------------------------------------------------------------


def _env_rng_state(env: Any) -> dict[str, Any]:
    from core.runs.trainer import _env_rng_state as state

    return state(env)


def _make_reset_recorder(env: Any) -> Any:
    """The training env, remembering its generator just before each reset (a checkpoint at an episode
    boundary is written after SB3's automatic reset; resuming replays that reset from this state) and the
    last step's ``terminated``/``truncated`` (SB3's VecEnv folds them into ``done``; ``env.success`` needs
    them as the trainer sees them)."""
    import gymnasium as gym

    class ResetRecorder(gym.Wrapper):
        def __init__(self, inner: Any) -> None:
            super().__init__(inner)
            self.before_reset: dict[str, Any] = _env_rng_state(inner)
            self.terminated = False
            self.truncated = False

        def reset(self, **kwargs: Any) -> Any:
            self.before_reset = _env_rng_state(self.env)
            return self.env.reset(**kwargs)

        def step(self, action: Any) -> Any:
            obs, reward, terminated, truncated, info = self.env.step(action)
            self.terminated, self.truncated = bool(terminated), bool(truncated)
            return obs, reward, terminated, truncated, info

    return ResetRecorder(env)


class GreedyPolicy:
    """``core.runs.trainer.evaluate``'s agent interface over an SB3 model: the deterministic action."""

    def __init__(self, model: Any) -> None:
        self.model = model

    def act(self, obs: np.ndarray, explore: bool = False) -> tuple[np.ndarray, dict[str, float]]:
        action, _ = self.model.predict(obs, deterministic=not explore)
        return np.asarray(action, dtype=np.float32), {}

    def start_value(self, obs: np.ndarray) -> float:
        """The critic's value of the deterministic action at ``obs`` (twins: the smaller), as our agents'."""
        return _critic_value(self.model, obs)


# -- SB3 state that a checkpoint adds to the model file ------------------------------------------


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


def _sde_state(model: Any) -> dict[str, torch.Tensor]:
    """gSDE's current exploration matrices (SAC with ``use_sde``), or nothing."""
    dist = getattr(getattr(model, "actor", None), "action_dist", None)
    if not getattr(model, "use_sde", False) or dist is None:
        return {}
    return {
        name: getattr(dist, name).detach().clone()
        for name in ("exploration_mat", "exploration_matrices")
        if isinstance(getattr(dist, name, None), torch.Tensor)
    }


def _restore_sde_state(model: Any, state: Mapping[str, torch.Tensor]) -> None:
    dist = getattr(getattr(model, "actor", None), "action_dist", None)
    for name, tensor in state.items():
        setattr(dist, name, tensor.clone())


def _pink_state(model: Any) -> dict[str, Any]:
    """The pink process of ``PinkNoiseDist`` (``sb3-sac-pink``): its sequence, position and generator."""
    gen = model.actor.action_dist.gen
    return {
        "buffer": torch.from_numpy(np.ascontiguousarray(gen.buffer)),
        "idx": int(gen.idx),
        "rng": generator_state(gen.rng),
    }


def _restore_pink_state(model: Any, state: Mapping[str, Any]) -> None:
    gen = model.actor.action_dist.gen
    gen.buffer = state["buffer"].numpy().copy()
    gen.idx = int(state["idx"])
    restore_generator(gen.rng, state["rng"])


def _start_value(model: Any) -> float:
    """The critic's value of the deterministic action at the observation the next step acts on:
    ``charts/start_value`` when taken at an episode's first step."""
    return _critic_value(model, model._last_obs)


@torch.no_grad()
def _critic_value(model: Any, observation: np.ndarray) -> float:
    """The critic's value of the deterministic action at ``observation`` (twins: the smaller), as our
    learners' ``value_of``. No random draw: the training that follows is unchanged."""
    obs, _ = model.policy.obs_to_tensor(observation)
    action = model.policy._predict(obs, deterministic=True)
    values = torch.cat(model.critic(obs, action), dim=1)
    return float(values.min(dim=1).values[0])


def _rollout_ends(train_freq: Any, steps: int, episodes: int) -> bool:
    """Whether SB3's rollout of ``train_freq`` is complete after ``steps`` steps and ``episodes`` episodes."""
    from stable_baselines3.common.utils import should_collect_more_steps

    return not should_collect_more_steps(train_freq, steps, episodes)


def _remaining(train_freq: Any, steps: int, episodes: int) -> Any:
    """The rest of a rollout of ``train_freq`` that has collected ``steps`` steps and ``episodes``
    episodes."""
    from stable_baselines3.common.type_aliases import TrainFreq, TrainFrequencyUnit

    if train_freq.unit == TrainFrequencyUnit.STEP:
        return TrainFreq(train_freq.frequency - steps, train_freq.unit)
    return TrainFreq(train_freq.frequency - episodes, train_freq.unit)


def _store_last_step(model: Any, local: Mapping[str, Any]) -> None:
    """What ``OffPolicyAlgorithm.collect_rollouts`` (SB3 2.x) does after the callback's ``on_step`` for the
    step in ``local`` (its local variables): store the transition, count a finished episode and reset the
    action noise — so ``learn`` can be left right after an episode's last step."""
    model._update_info_buffer(local["infos"], local["dones"])
    model._store_transition(
        local["replay_buffer"],
        local["buffer_actions"],
        local["new_obs"],
        local["rewards"],
        local["dones"],
        local["infos"],
    )
    model._update_current_progress_remaining(model.num_timesteps, model._total_timesteps)
    model._on_step()
    for done in local["dones"]:
        if done:
            model._episode_num += 1
            if local["action_noise"] is not None:
                local["action_noise"].reset()


@dataclasses.dataclass
class _Continuation:
    """Where a rollout was left: applied at the next rollout start of ``learn`` (re-entered or resumed)."""

    steps: int = 0
    """Steps the rollout had collected (0: the checkpoint was taken at a rollout start)."""
    episodes: int = 0
    torch_rng: torch.Tensor | None = None
    sde: Mapping[str, torch.Tensor] = dataclasses.field(default_factory=dict)


# -- the run ------------------------------------------------------------------------------------


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
        pink: bool = False,
    ) -> None:
        if algo not in SB3_ALGOS.values():
            raise ConfigError(f"unknown SB3 algorithm {algo!r} (choose from {', '.join(SB3_ALGOS.values())})")
        if pink and algo != "sac":
            raise ConfigError(f"pink noise's SB3 peer is SAC's (sb3-sac-pink), not {algo}'s")
        self.algo = algo
        self.pink = pink
        self.name = "sb3-sac-pink" if pink else f"sb3-{algo}"
        require_sb3(self.name)
        if config.run.algo != self.name:
            config = dataclasses.replace(config, run=dataclasses.replace(config.run, algo=self.name))
        super().__init__(config, run_dir, resume, on_episode, should_stop, command)

    # -- setup ----------------------------------------------------------------------------------
    def _check_checkpoint(self, checkpoint: Mapping[str, Any]) -> None:
        if checkpoint.get("sb3", {}).get("format") != _SB3_FORMAT:
            raise RunDirectoryError(f"{self.dir.latest_path} is not a Stable-Baselines3 run's checkpoint")

    def _build(
        self, venv: Any, settings: SB3Settings, checkpoint: dict[str, Any] | None, seq_len: int
    ) -> Any:
        model = self._build_model(venv, settings, checkpoint)
        if self.pink:
            use_pink_noise(model, seq_len, self.config.run.seed)
            if checkpoint is not None:
                _restore_pink_state(model, checkpoint["sb3"]["pink"])
        return model

    def _build_model(self, venv: Any, settings: SB3Settings, checkpoint: dict[str, Any] | None) -> Any:
        cfg = self.config.run
        if checkpoint is None:
            return make_model(settings, self.algo, venv, seed=cfg.seed, device=cfg.device)
        sb3 = checkpoint["sb3"]
        extra = {"action_noise": settings.kwargs["action_noise"]} if "action_noise" in settings.kwargs else {}
        model = algorithm_class(self.algo).load(
            self.dir.checkpoints / sb3["model"], env=venv, device=cfg.device, **extra
        )
        replay = torch.load(self.dir.checkpoints / sb3["replay"], map_location="cpu", weights_only=True)
        _load_replay_state(model.replay_buffer, replay)
        # learn() resets the env as the trainer's resume does: from the restored generator, with no seed
        # (load() re-seeds the VecEnv with the run's seed for its next reset; drop that)
        model._last_obs = None
        venv._reset_seeds()
        return model

    def _restore(self, checkpoint: dict[str, Any], model: Any, env: Any) -> _Continuation:
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
        rollout = checkpoint["sb3"].get("rollout", {})
        return _Continuation(
            steps=int(rollout.get("steps", 0)),
            episodes=int(rollout.get("episodes", 0)),
            torch_rng=rngs["torch"],
            sde=checkpoint["sb3"].get("sde", {}),
        )

    def _write_hyperparams(self, settings: SB3Settings, model: Any) -> None:
        record = hyperparams_record(settings, self.algo, model, self.config)
        atomic_write_text(self.dir.root / HYPERPARAMS_FILE, json.dumps(record, indent=2) + "\n")

    # -- checkpoints ----------------------------------------------------------------------------
    def _save_latest(
        self, model: Any, env_rng: dict[str, Any], wall_s: float, rollout: tuple[int, int] = (0, 0)
    ) -> None:
        """``latest.pt`` and its model/replay pair; ``rollout``: (steps, episodes) the current rollout had
        collected, (0, 0) at a rollout start."""
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
                    "rollout": {"steps": int(rollout[0]), "episodes": int(rollout[1])},
                    "sde": _sde_state(model),
                    **({"pink": _pink_state(model)} if self.pink else {}),
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

        result = evaluate(
            GreedyPolicy(model),  # type: ignore[arg-type]
            eval_env,
            self.config.run.eval_episodes,
            success_rule=self.config.env.success,
            gamma=float(model.gamma),
        )
        if self._record_evaluation(result):
            atomic_write_bytes(self.dir.checkpoints / "best.zip", _model_bytes(model))
        return result

    # -- the loop -------------------------------------------------------------------------------
    def run(self) -> dict[str, Any]:
        from stable_baselines3.common.vec_env import DummyVecEnv

        from core.runs.trainer import make_env

        checkpoint = self._begin()
        cfg = self.config
        adapted = make_env(cfg)
        env = adapted.env
        recorder = _make_reset_recorder(env)
        venv = DummyVecEnv([lambda: recorder])
        self.eval_env: Any = None
        try:
            settings = sb3_settings(cfg, self.algo, adapted.spec)
            model = self._build(venv, settings, checkpoint, episode_limit(env) or DEFAULT_SEQ_LEN)
            self._write_hyperparams(settings, model)
            continuation = None
            if checkpoint is not None:
                continuation = self._restore(checkpoint, model, env)
            self._start_clock()
            callback = self._callback(model, recorder, env, continuation)
            with self.stop_flag:
                first = checkpoint is None
                while True:
                    with contextlib.suppress(_EndOfRun):  # the callback ends the run at an episode boundary
                        model.learn(
                            total_timesteps=10**12,
                            callback=callback,
                            reset_num_timesteps=first,
                            log_interval=None,  # type: ignore[arg-type]
                        )
                    first = False
                    if callback.continuation is None:
                        break
                    # the callback left learn() inside a rollout for a checkpoint: go on from there
                final_eval: dict[str, float] = {}
                if self._final_evaluation_due():
                    self.eval_env = self.eval_env or make_env(cfg, evaluation=True).env
                    final_eval = self._evaluate(model, self.eval_env)
            # at an episode boundary the env was already reset for the next episode: resume replays it
            env_rng = recorder.before_reset if callback.at_boundary else _env_rng_state(env)
            self._save_latest(model, env_rng, self.wall(), callback.rollout_progress())
            return self._finish(final_eval, ac=None)
        finally:
            venv.close()
            if self.eval_env is not None:
                self.eval_env.close()

    def _callback(self, model: Any, recorder: Any, env: Any, continuation: _Continuation | None) -> Any:
        from stable_baselines3.common.callbacks import BaseCallback

        from core.runs.trainer import make_env

        run = self
        train_freq = model.train_freq
        gradient_steps = model.gradient_steps
        if continuation is not None and (continuation.steps or continuation.episodes):
            model.train_freq = _remaining(train_freq, continuation.steps, continuation.episodes)

        class EpisodeRecords(BaseCallback):
            """Per step: sum the episode, poll the stop flag, close an episode that ends inside a rollout.
            At the next rollout start (after the update): close an episode that ended on the rollout's last
            step, and end the run when due. See the module docstring."""

            def __init__(self) -> None:
                super().__init__(verbose=0)
                self.episode_return = 0.0
                self.length = 0
                self.start_value = math.nan
                self.discounted = 0.0
                self.discount = 1.0
                self.finished: dict[str, Any] | None = None
                self.losses: list[dict[str, float]] = []
                self.n_updates = int(model._n_updates)
                self.at_boundary = True
                self.rollout_steps = 0
                self.rollout_episodes = 0
                self.continuation: _Continuation | None = continuation
                """Set when the rollout was left in the middle (or resumed): applied at the next start."""

            def rollout_progress(self) -> tuple[int, int]:
                return self.rollout_steps, self.rollout_episodes

            def _on_training_start(self) -> None:
                # SB3's schedules see progress_remaining = 1 - num_timesteps / _total_timesteps: our budget
                if run.config.run.steps is not None:
                    model._total_timesteps = int(run.config.run.steps)

            def _on_rollout_start(self) -> None:
                model.gradient_steps = gradient_steps
                if self.continuation is not None:
                    self._continue(self.continuation)
                    self.continuation = None
                    return
                self.rollout_steps = self.rollout_episodes = 0
                self._collect_losses()
                if self.finished is not None:
                    self._close(self.finished)
                    self.finished = None
                    if run._checkpoint_due():
                        run._save_latest(model, recorder.before_reset, run.wall())
                        run.last_checkpoint = time.perf_counter()
                if run.stopped or run.stop_flag():
                    run.stopped = True
                    raise _EndOfRun
                if self.at_boundary and run._budget_spent():
                    raise _EndOfRun

            def _continue(self, where: _Continuation) -> None:
                """The first rollout start after leaving ``learn`` mid-rollout, or after a resume: the rollout
                goes on from ``where`` (SB3 has just resampled gSDE noise; put back the matrices and the
                torch generator of the moment the rollout was left)."""
                model.train_freq = train_freq
                self.rollout_steps, self.rollout_episodes = where.steps, where.episodes
                if where.torch_rng is not None:
                    torch.set_rng_state(where.torch_rng)
                _restore_sde_state(model, where.sde)

            def _on_rollout_end(self) -> None:
                # gradient_steps=-1 trains as many steps as the rollout collected: all of it, not the rest
                if gradient_steps < 0:
                    model.gradient_steps = self.rollout_steps

            def _on_step(self) -> bool:
                if self.length == 0:  # an episode's first step: weights as after the last one's update
                    self.start_value = _start_value(model)
                    self.discounted, self.discount = 0.0, 1.0
                run.global_step += 1
                self.length += 1
                self.rollout_steps += 1
                reward = float(self.locals["rewards"][0])
                self.episode_return += reward
                self.discounted += self.discount * reward
                self.discount *= float(model.gamma)
                self.at_boundary = False
                keep_going = True
                if bool(self.locals["dones"][0]):
                    info = self.locals["infos"][0]
                    finished = {
                        "return": self.episode_return,
                        "length": self.length,
                        "success": episode_success(
                            info, recorder.terminated, recorder.truncated, run.config.env.success
                        ),
                        "toppled": bool(info.get("toppled", False)),
                        "measured": env_diagnostics(info),
                        "start_value": self.start_value,
                        "discounted_return": self.discounted,
                    }
                    self.episode_return, self.length = 0.0, 0
                    self.at_boundary = True
                    self.rollout_episodes += 1
                    if _rollout_ends(train_freq, self.rollout_steps, self.rollout_episodes):
                        self.finished = finished  # closed after this rollout's update
                    else:
                        keep_going = self._close_inside_rollout(finished)
                if run.stop_flag():
                    run.stopped = True
                return keep_going

            def _close_inside_rollout(self, finished: dict[str, Any]) -> bool:
                """Close an episode that ended inside a rollout. When a checkpoint, a stop or the end of the
                budget falls here: store the step as SB3 would, checkpoint (unless the run ends: ``run``
                writes the last one), and return False to leave ``learn``."""
                self._close(finished)
                end = run.stopped or run.stop_flag() or run._budget_spent()
                checkpoint = run._checkpoint_due()
                if not (end or checkpoint):
                    return True
                _store_last_step(model, self.locals)
                if end:
                    run.stopped = run.stopped or run.stop_flag()
                    return False
                run._save_latest(model, recorder.before_reset, run.wall(), self.rollout_progress())
                run.last_checkpoint = time.perf_counter()
                self.continuation = _Continuation(
                    steps=self.rollout_steps,
                    episodes=self.rollout_episodes,
                    torch_rng=torch.get_rng_state(),
                    sde=_sde_state(model),
                )
                model.train_freq = _remaining(train_freq, self.rollout_steps, self.rollout_episodes)
                return False

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

            def _close(self, finished: dict[str, Any]) -> None:
                """The episode record (with the losses of the updates since the last one) and an evaluation
                when due."""
                record = run._new_record(
                    finished["return"], finished["length"], finished["success"], finished["toppled"]
                )
                record.update(mean_dicts(self.losses))
                record.update(finished["measured"])
                record["charts/start_value"] = finished["start_value"]
                record["charts/discounted_return"] = finished["discounted_return"]
                self.losses = []
                if run._evaluation_due():
                    run.eval_env = run.eval_env or make_env(run.config, evaluation=True).env
                    record.update(run._evaluate(model, run.eval_env))
                run._log_episode(record)

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
    pink: bool = False,
) -> dict[str, Any]:
    """Train SB3 ``algo`` (``sac``, ``td3`` or ``ddpg``) into ``run_dir`` (or continue it); returns the
    summary. ``pink=True`` (SAC only): ``sb3-sac-pink``, the actor sampling through ``PinkNoiseDist``.

    Same contract as :func:`core.runs.trainer.train` (see the module docstring); ``config.run.algo`` is set to
    ``sb3-<algo>``. Raises ExperimentError (one line) when Stable-Baselines3 is not installed, or when
    ``agent.sb3_hyperparams=zoo`` and RL Zoo has no usable entry for ``env.id``.
    """
    return _SB3Run(config, Path(run_dir), algo, resume, on_episode, should_stop, command, pink).run()


# -- the experiment runner's cell runner ------------------------------------------------------


class SB3Runner(ConfigCellRunner):
    """Cells of ``sb3-sac`` / ``sb3-td3`` / ``sb3-ddpg`` / ``sb3-sac-pink``: ``core.config`` (profile →
    overrides → the cell's keys, as for every method) + :func:`train_sb3`. ``run.algo`` is the SB3 name
    (not in ``core.runs.methods``). With ``agent.sb3_hyperparams=zoo`` the zoo's entry for the env is checked
    here, so a task without one fails before anything is written."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.algo = SB3_ALGOS[name]
        self.pink = name in PINK_PEERS

    def resolve(self, spec: ExperimentSpec, method: MethodSpec, reward: str, seed: int) -> dict[str, Any]:
        from core.config import load_config

        require_sb3(self.name)
        if method.ac is not None:
            raise ExperimentError(
                f"bad value for ac: method {method.label!r} ({self.name}) has no actor-update rule of ours"
            )
        items = cell_overrides(spec, method, reward, seed, algo=self.name)

        def build() -> Config:
            config = load_config(spec.profile, items)
            if config.agent.sb3_hyperparams == "zoo":
                from core.experiments.sb3_zoo import zoo_entry

                zoo_entry(self.algo, config.env.id)
            return config

        return self._checked_config(method, reward, build)

    def training_function(self) -> Callable[..., dict[str, Any]]:
        return functools.partial(train_sb3, algo=self.algo, pink=self.pink)
