"""The one training loop every method shares (Algorithm 2/3's outer loops), with evaluation, metrics,
checkpoints and resume.

``train(config, run_dir, resume=..., on_episode=..., should_stop=...) -> summary``

Per training episode: reset the env, ``agent.begin_episode``; per step ``agent.act(obs, explore=True)``,
``env.step``, ``agent.observe``, ``agent.update_after_step``; at the end ``agent.update_after_episode`` and
``agent.episode_diagnostics``. The episode record (CleanRL-style keys, see ``RECORD_KEYS``) goes to
metrics.csv and to ``on_episode``. Losses are the mean over the episode's updates (blank/NaN when none).

* Seeding: ``torch.manual_seed(seed)``; the agent gets ``np.random.default_rng(SeedSequence(seed).spawn)``
  for exploration noise and replay sampling; the training env is reset with ``seed`` once, then continues
  its own generator (so ``env.fixed_positions`` cycles as the env defines). Same seed → same metrics.
* Evaluation: every ``run.eval_every`` episodes and once at the end, ``run.eval_episodes`` greedy episodes
  (``agent.act(obs, explore=False)``) on a separate env with new random graspable positions
  (``fixed_positions=None``) from the fixed seeds ``EVAL_SEED + k`` — the same positions for every run and
  every evaluation, so success rates compare directly. ``best.pt`` keeps the policy of the best
  evaluation (success rate, then return).
* Budget: ``run.episodes``, ``run.steps`` and ``run.max_wall_s``, checked at episode boundaries (the run
  ends at the first boundary at or past any of them).
* Checkpoints: ``latest.pt`` + ``replay.pt`` every ``run.checkpoint_every`` episodes, and at the first
  episode end ``run.checkpoint_every_s`` seconds after the previous checkpoint (so a killed process loses
  at most about that much training), and when the run ends or stops.
* Stopping: ``should_stop()`` is polled every step; Ctrl-C (SIGINT, when called from the main thread)
  sets the same flag (a second Ctrl-C aborts at once). A stop abandons the current episode (its
  transitions stay in the replay buffer and in ``global_step``), writes ``latest.pt`` + ``replay.pt``
  and a summary with ``"stopped": true``.
* Resume: ``resume=True`` loads ``checkpoints/latest.pt`` and ``replay.pt`` from ``run_dir``: agent
  (weights, optimisers, counters, noise/replay RNG), torch RNG, the training env's generator and episode
  index, counters, eval history; metrics.csv rows after the checkpoint are dropped. The run continues
  with the budget of the ``config`` passed in; its ``net``, ``env``, ``agent``, ``dual`` sections and
  ``run.algo`` must match the saved run.
"""

from __future__ import annotations

import math
import shlex
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.agent import Agent, EnvSpec, Transition, generator_state, restore_generator
from core.algos import make_agent, resolve_algo
from core.config import Config, ConfigError, check_config, resolve_level_defaults
from core.metrics import area_under_curve, final_performance
from core.run_dir import (
    CHECKPOINT_FORMAT,
    MetricsCSV,
    RunDirectory,
    RunDirectoryError,
    atomic_torch_save,
    load_checkpoint,
)

EVAL_SEED = 1_000_000
"""Evaluation episode k resets its env with seed EVAL_SEED + k (same positions for all runs)."""

RECORD_KEYS: tuple[str, ...] = (
    "episode",
    "global_step",
    "charts/episodic_return",
    "charts/success",
    "charts/toppled",
    "charts/length",
    "losses/critic",
    "losses/rec",
    "losses/actor",
    "time/wall_s",
    "charts/sps",
    "eval/success_rate",
    "eval/return",
)
"""Keys present in every episode record (and metrics.csv column order); agents add their own."""

EpisodeCallback = Callable[[dict[str, Any]], None]


class _StopFlag:
    """should_stop() or Ctrl-C; the SIGINT handler is installed only in the main thread."""

    def __init__(self, should_stop: Callable[[], bool] | None) -> None:
        self.should_stop = should_stop
        self.interrupted = False
        self._previous: Any = None

    def __enter__(self) -> _StopFlag:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._on_sigint)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)

    def _on_sigint(self, signum: int, frame: Any) -> None:
        if self.interrupted:
            raise KeyboardInterrupt
        self.interrupted = True

    def __call__(self) -> bool:
        return self.interrupted or (self.should_stop is not None and bool(self.should_stop()))


def env_kwargs(config: Config) -> dict[str, Any]:
    """The ``NicoGraspEnv`` keyword arguments of ``config.env``."""
    env = config.env
    return {
        "level": env.level,
        "reward_mode": env.reward_mode,
        "hand": env.hand,
        "dense_shaping": env.dense_shaping,
        "fixed_positions": env.fixed_positions,
        "max_steps": env.max_steps,
        "domain": env.domain,
    }


def make_env(config: Config, *, evaluation: bool = False) -> Any:
    """The training env, or the evaluation env (random graspable positions every reset)."""
    from core.envs import NicoGraspEnv

    kwargs = env_kwargs(config)
    if evaluation:
        kwargs["fixed_positions"] = None
    return NicoGraspEnv(**kwargs)


def env_spec(env: Any) -> EnvSpec:
    space = env.action_space
    return EnvSpec(
        obs_shape=tuple(env.observation_space.shape),
        action_dim=int(space.shape[0]),
        action_low=float(space.low.min()),
        action_high=float(space.high.max()),
    )


def evaluate(agent: Agent, env: Any, episodes: int, seed: int = EVAL_SEED) -> dict[str, float]:
    """Greedy episodes (no noise): success rate, mean episodic return and mean length."""
    successes, returns, lengths = [], [], []
    for k in range(episodes):
        obs, _ = env.reset(seed=seed + k)
        total, length, success = 0.0, 0, False
        while True:
            action, _ = agent.act(obs, explore=False)
            obs, reward, terminated, truncated, info = env.step(action)
            total += reward
            length += 1
            if terminated or truncated:
                success = bool(info.get("success", False))
                break
        successes.append(success)
        returns.append(total)
        lengths.append(length)
    return {
        "eval/success_rate": float(np.mean(successes)),
        "eval/return": float(np.mean(returns)),
        "eval/length": float(np.mean(lengths)),
    }


def _env_rng_state(env: Any) -> dict[str, Any]:
    unwrapped = env.unwrapped
    return {
        "np_random": generator_state(unwrapped.np_random),
        "episode_index": int(getattr(unwrapped, "_episode_index", 0)),
    }


def _restore_env_rng(env: Any, state: dict[str, Any]) -> None:
    unwrapped = env.unwrapped
    rng = np.random.default_rng()
    restore_generator(rng, state["np_random"])
    unwrapped.np_random = rng
    if hasattr(unwrapped, "_episode_index"):
        unwrapped._episode_index = int(state["episode_index"])


def _mean_dicts(items: list[dict[str, float]]) -> dict[str, float]:
    sums: dict[str, float] = {}
    counts: dict[str, int] = {}
    for item in items:
        for key, value in item.items():
            sums[key] = sums.get(key, 0.0) + float(value)
            counts[key] = counts.get(key, 0) + 1
    return {key: sums[key] / counts[key] for key in sums}


class _Trainer:
    """State of one ``train`` call; see the module docstring."""

    def __init__(
        self,
        config: Config,
        run_dir: Path,
        resume: bool,
        on_episode: EpisodeCallback | None,
        should_stop: Callable[[], bool] | None,
        command: str | None,
    ) -> None:
        self.config = resolve_level_defaults(resolve_algo(config))
        check_config(self.config)
        self.dir = RunDirectory(run_dir)
        self.on_episode = on_episode
        self.stop_flag = _StopFlag(should_stop)
        self.command = command if command is not None else shlex.join(sys.argv)
        self.episode = 0
        self.global_step = 0
        self.wall_offset = 0.0
        self.returns: list[float] = []
        self.successes: list[float] = []
        self.evals: list[tuple[int, float]] = []
        self.best: tuple[float, float] | None = None
        self.last_eval: dict[str, float] = {}
        self.resume = resume

    # -- setup -----------------------------------------------------------------------------------
    def _prepare(self) -> dict[str, Any] | None:
        checkpoint = None
        if self.resume:
            checkpoint = load_checkpoint(self.dir.latest_path)
            saved = Config.from_dict(checkpoint["config"])
            for section in ("net", "env", "agent", "dual"):
                if getattr(saved, section) != getattr(self.config, section):
                    raise ConfigError(
                        f"cannot resume {self.dir.root}: config section {section!r} differs "
                        "from the saved run"
                    )
            if saved.run.algo != self.config.run.algo:
                raise ConfigError(f"cannot resume {self.dir.root}: it was trained with {saved.run.algo!r}")
        elif self.dir.holds_run():
            raise RunDirectoryError(f"run directory {self.dir.root} already holds a run (resume it instead)")
        self.dir.create()
        self.dir.write_config(self.config)
        self.dir.append_command(self.command)
        return checkpoint

    def _restore(self, checkpoint: dict[str, Any], agent: Agent, env: Any) -> None:
        counters = checkpoint["counters"]
        self.episode = int(counters["episode"])
        self.global_step = int(counters["global_step"])
        self.wall_offset = float(counters["wall_s"])
        best = counters.get("best")
        self.best = (float(best[0]), float(best[1])) if best else None
        self.evals = [(int(e), float(s)) for e, s in checkpoint["evals"]]
        agent.load_state_dict(checkpoint["agent"])
        agent.load_replay_state_dict(torch.load(self.dir.replay_path, map_location="cpu", weights_only=True))
        torch.set_rng_state(checkpoint["torch_rng"])
        _restore_env_rng(env, checkpoint["env_rng"])
        self.csv.truncate_after(self.episode)
        self.returns = self.csv.column("charts/episodic_return")
        self.successes = self.csv.column("charts/success")

    # -- checkpoints ----------------------------------------------------------------------------
    def _counters(self, wall_s: float) -> dict[str, Any]:
        return {
            "episode": self.episode,
            "global_step": self.global_step,
            "wall_s": wall_s,
            "best": list(self.best) if self.best else None,
        }

    def _save_latest(self, agent: Agent, env: Any, wall_s: float) -> None:
        atomic_torch_save(agent.replay_state_dict(), self.dir.replay_path)
        atomic_torch_save(
            {
                "format": CHECKPOINT_FORMAT,
                "config": self.config.to_dict(),
                "obs_shape": list(self.spec.obs_shape),
                "action_dim": self.spec.action_dim,
                "counters": self._counters(wall_s),
                "evals": [list(item) for item in self.evals],
                "agent": agent.state_dict(),
                "policy": agent.policy_state(),
                "torch_rng": torch.get_rng_state(),
                "env_rng": _env_rng_state(env),
            },
            self.dir.latest_path,
        )

    def _save_best(self, agent: Agent, wall_s: float, evaluation: dict[str, float]) -> None:
        atomic_torch_save(
            {
                "format": CHECKPOINT_FORMAT,
                "config": self.config.to_dict(),
                "obs_shape": list(self.spec.obs_shape),
                "action_dim": self.spec.action_dim,
                "counters": self._counters(wall_s),
                "eval": evaluation,
                "policy": agent.policy_state(),
            },
            self.dir.best_path,
        )

    # -- the loop --------------------------------------------------------------------------------
    def run(self) -> dict[str, Any]:
        checkpoint = self._prepare()
        cfg = self.config
        torch.set_num_threads(max(1, cfg.run.num_threads))
        torch.manual_seed(cfg.run.seed)
        agent_rng = np.random.default_rng(np.random.SeedSequence(cfg.run.seed).spawn(1)[0])
        env = make_env(cfg)
        eval_env = None
        self.csv = MetricsCSV(self.dir.metrics_path)
        try:
            self.spec = env_spec(env)
            agent = make_agent(cfg, self.spec, agent_rng)
            first_reset_seed: int | None = cfg.run.seed
            if checkpoint is not None:
                self._restore(checkpoint, agent, env)
                first_reset_seed = None
            start_time = time.perf_counter()
            last_checkpoint = start_time
            start_step = self.global_step
            stopped = False

            def wall() -> float:
                return self.wall_offset + time.perf_counter() - start_time

            with self.stop_flag:
                while not self._budget_spent(wall()):
                    if self.stop_flag():
                        stopped = True
                        break
                    record = self._train_episode(agent, env, first_reset_seed)
                    first_reset_seed = None
                    if record is None:
                        stopped = True
                        break
                    if cfg.run.eval_every > 0 and self.episode % cfg.run.eval_every == 0:
                        eval_env = eval_env or make_env(cfg, evaluation=True)
                        record.update(self._evaluate(agent, eval_env, wall()))
                    elapsed = time.perf_counter() - start_time
                    record["time/wall_s"] = wall()
                    record["charts/sps"] = (self.global_step - start_step) / max(elapsed, 1e-9)
                    self.csv.append(record)
                    if self.on_episode is not None:
                        self.on_episode(dict(record))
                    if self._checkpoint_due(time.perf_counter() - last_checkpoint):
                        self._save_latest(agent, env, wall())
                        last_checkpoint = time.perf_counter()
                final_eval = {}
                if (
                    not stopped
                    and cfg.run.final_eval
                    and (not self.evals or self.evals[-1][0] != self.episode)
                ):
                    eval_env = eval_env or make_env(cfg, evaluation=True)
                    final_eval = self._evaluate(agent, eval_env, wall())
            self._save_latest(agent, env, wall())
            summary = self._summary(
                wall(),
                (self.global_step - start_step) / max(time.perf_counter() - start_time, 1e-9),
                stopped,
                final_eval,
            )
            self.dir.write_summary(summary)
            self.dir.write_learning_curve(
                self.returns,
                self.evals,
                cfg.run.smoothing_window,
                f"{cfg.run.algo} · {cfg.env.reward_mode} reward · seed {cfg.run.seed}",
                diagnostics={k: self.csv.column(k) for k in self.csv.columns if k.startswith("dual/")},
            )
            return summary
        finally:
            env.close()
            if eval_env is not None:
                eval_env.close()

    def _checkpoint_due(self, since_last_s: float) -> bool:
        """Every ``run.checkpoint_every`` episodes, or ``run.checkpoint_every_s`` s after the last one."""
        run = self.config.run
        by_episode = run.checkpoint_every > 0 and self.episode % run.checkpoint_every == 0
        by_time = run.checkpoint_every_s is not None and since_last_s >= run.checkpoint_every_s
        return by_episode or by_time

    def _budget_spent(self, wall_s: float) -> bool:
        run = self.config.run
        return (
            (run.episodes is not None and self.episode >= run.episodes)
            or (run.steps is not None and self.global_step >= run.steps)
            or (run.max_wall_s is not None and wall_s >= run.max_wall_s)
        )

    def _train_episode(self, agent: Agent, env: Any, reset_seed: int | None) -> dict[str, Any] | None:
        obs, _ = env.reset(seed=reset_seed)
        agent.begin_episode(obs)
        episode_return, length, success, toppled = 0.0, 0, False, False
        losses: list[dict[str, float]] = []
        step_diagnostics: list[dict[str, float]] = []
        while True:
            if self.stop_flag():
                return None
            action, diagnostics = agent.act(obs, explore=True)
            if diagnostics:
                step_diagnostics.append(diagnostics)
            next_obs, reward, terminated, truncated, info = env.step(action)
            agent.observe(Transition(obs, action, float(reward), next_obs, bool(terminated), bool(truncated)))
            self.global_step += 1
            length += 1
            episode_return += float(reward)
            step_losses = agent.update_after_step()
            if step_losses:
                losses.append(step_losses)
            obs = next_obs
            if terminated or truncated:
                success, toppled = bool(info.get("success", False)), bool(info.get("toppled", False))
                break
        episode_losses = agent.update_after_episode()
        if episode_losses:
            losses.append(episode_losses)
        self.episode += 1
        self.returns.append(episode_return)
        self.successes.append(float(success))
        record: dict[str, Any] = dict.fromkeys(RECORD_KEYS, math.nan)
        record.update(
            {
                "episode": self.episode,
                "global_step": self.global_step,
                "charts/episodic_return": episode_return,
                "charts/success": int(success),
                "charts/toppled": int(toppled),
                "charts/length": length,
            }
        )
        record.update(_mean_dicts(losses))
        record.update(_mean_dicts(step_diagnostics))
        record.update(agent.episode_diagnostics())
        return record

    def _evaluate(self, agent: Agent, eval_env: Any, wall_s: float) -> dict[str, float]:
        result = evaluate(agent, eval_env, self.config.run.eval_episodes)
        self.last_eval = result
        self.evals.append((self.episode, result["eval/success_rate"]))
        score = (result["eval/success_rate"], result["eval/return"])
        if self.best is None or score > self.best:
            self.best = score
            self._save_best(agent, wall_s, result)
        return result

    def _summary(
        self, wall_s: float, sps: float, stopped: bool, final_eval: dict[str, float]
    ) -> dict[str, Any]:
        last_eval = final_eval or self.last_eval
        recent = self.successes[-100:]
        return {
            "run_dir": str(self.dir.root),
            "algo": self.config.run.algo,
            "ac": self.config.agent.ac,
            "reward": self.config.env.reward_mode,
            "seed": self.config.run.seed,
            "episodes": self.episode,
            "steps": self.global_step,
            "final_perf": final_performance(self.returns),
            "auc": area_under_curve(self.returns),
            "auc_from_minus1": area_under_curve(self.returns, baseline=-1.0),
            "success_rate": last_eval.get("eval/success_rate", math.nan),
            "eval_return": last_eval.get("eval/return", math.nan),
            "eval_episodes": self.config.run.eval_episodes if last_eval else 0,
            "best_success_rate": self.best[0] if self.best else math.nan,
            "train_success_rate_last100": float(np.mean(recent)) if recent else math.nan,
            "wall_s": wall_s,
            "sps": sps,
            "stopped": stopped,
        }


def train(
    config: Config,
    run_dir: Path | str,
    *,
    resume: bool = False,
    on_episode: EpisodeCallback | None = None,
    should_stop: Callable[[], bool] | None = None,
    command: str | None = None,
) -> dict[str, Any]:
    """Train ``config.run.algo`` into ``run_dir`` (or continue it with ``resume=True``); returns the summary.

    ``on_episode(record)`` receives each episode record (the metrics.csv row); ``should_stop()`` is polled
    every step and ends the run with a resumable checkpoint. ``command`` is recorded in command.txt
    (default: this process's argv).
    """
    return _Trainer(config, Path(run_dir), resume, on_episode, should_stop, command).run()
