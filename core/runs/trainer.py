"""The one training loop every method shares (Algorithm 2/3's outer loops), with evaluation, metrics,
checkpoints and resume.

``train(config, run_dir, resume=..., on_episode=..., should_stop=...) -> summary``

Per training episode: reset the env, ``agent.begin_episode``; per step ``agent.act(obs, explore=True)``,
``env.step``, ``agent.observe``, ``agent.update_after_step``; at the end ``agent.update_after_episode`` and
``agent.episode_diagnostics``. The episode record (CleanRL-style keys, see ``RECORD_KEYS``) goes to
metrics.csv and to ``on_episode``. Losses are the mean over the episode's updates (blank/NaN when none).
An env may measure its own episode: a dict of floats in ``info["episode_diagnostics"]`` on an episode's
last step goes into that episode's record as it is (``core.runs.bookkeeping.env_diagnostics``;
``dualsys/ThreeRegions-v0``'s ``env/noise_share`` and ``env/coverage_rest``).
The run's bookkeeping, shared with the Stable-Baselines3 peer (run-directory set-up and resume check,
counters, episode records, evaluation/checkpoint/budget schedules, summary.json), is
:class:`core.runs.bookkeeping.RunBookkeeping`'s.

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

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import Config
from core.envs import gym_env
from core.envs.gym_env import AdaptedEnv, episode_success
from core.modelfree.agent import Agent, Transition, generator_state, restore_generator
from core.runs.bookkeeping import RECORD_KEYS as RECORD_KEYS
from core.runs.bookkeeping import EpisodeCallback as EpisodeCallback
from core.runs.bookkeeping import RunBookkeeping, env_diagnostics, mean_dicts
from core.runs.methods import make_agent, resolve_algo
from core.runs.run_dir import atomic_torch_save

EVAL_SEED = 1_000_000
"""Evaluation episode k resets its env with seed EVAL_SEED + k (same positions for all runs)."""


def make_env(config: Config, *, evaluation: bool = False) -> AdaptedEnv:
    """The training env of ``config.env``, or its evaluation env (``core.envs.gym_env.make_env``)."""
    return gym_env.make_env(config.env, evaluation=evaluation)


def evaluate(
    agent: Agent,
    env: Any,
    episodes: int,
    seed: int = EVAL_SEED,
    success_rule: str = "info",
    gamma: float | None = None,
) -> dict[str, float]:
    """Greedy episodes (no noise): success rate (``env.success``'s rule), mean episodic return and length.

    With ``gamma``, also the overestimation pair of the policy the critic evaluates: the mean over the
    episodes of the critic's value of the start state at the greedy action (``agent.start_value``, where the
    agent has one) and of the discounted return Σ_t γ^t r_t the greedy episode earned. For a deterministic
    learner Q(s₀, μ(s₀)) estimates exactly that return; the training episodes' pair
    (``charts/start_value``, ``charts/discounted_return``) also holds the exploration's effect on the return.
    Neither draws a random number, so training is unchanged.
    """
    successes, returns, lengths, start_values, discounted_returns = [], [], [], [], []
    for k in range(episodes):
        obs, _ = env.reset(seed=seed + k)
        if gamma is not None and hasattr(agent, "start_value"):
            start_values.append(agent.start_value(obs))
        total, discounted, discount, length, success = 0.0, 0.0, 1.0, 0, False
        while True:
            action, _ = agent.act(obs, explore=False)
            obs, reward, terminated, truncated, info = env.step(action)
            total += reward
            discounted += discount * float(reward)
            discount *= gamma if gamma is not None else 1.0
            length += 1
            if terminated or truncated:
                success = episode_success(info, terminated, truncated, success_rule)
                break
        successes.append(success)
        returns.append(total)
        lengths.append(length)
        discounted_returns.append(discounted)
    result = {
        "eval/success_rate": float(np.mean(successes)),
        "eval/return": float(np.mean(returns)),
        "eval/length": float(np.mean(lengths)),
    }
    if gamma is not None:
        result["eval/discounted_return"] = float(np.mean(discounted_returns))
        if start_values:
            result["eval/start_value"] = float(np.mean(start_values))
    return result


def _env_rng_state(env: Any) -> dict[str, Any]:
    """The env's random state: a NumPy ``Generator`` (gymnasium's ``np_random``) or, for dm_control tasks
    through shimmy, the task's legacy ``RandomState``."""
    unwrapped = env.unwrapped
    rng = unwrapped.np_random
    if isinstance(rng, np.random.RandomState):
        state = rng.get_state(legacy=False)
        state["state"] = {key: np.asarray(value).tolist() for key, value in state["state"].items()}
        random_state = json.dumps(state)
        return {"random_state": random_state, "episode_index": 0}
    return {
        "np_random": generator_state(rng),
        "episode_index": int(getattr(unwrapped, "_episode_index", 0)),
    }


def _restore_env_rng(env: Any, state: dict[str, Any]) -> None:
    unwrapped = env.unwrapped
    if "random_state" in state:
        saved = json.loads(state["random_state"])
        saved["state"] = {key: np.asarray(value, dtype=np.uint64 if key == "key" else None)
                          for key, value in saved["state"].items()}
        unwrapped.np_random.set_state(saved)
        return
    rng = np.random.default_rng()
    restore_generator(rng, state["np_random"])
    unwrapped.np_random = rng
    if hasattr(unwrapped, "_episode_index"):
        unwrapped._episode_index = int(state["episode_index"])


class _Trainer(RunBookkeeping):
    """State of one ``train`` call; see the module docstring."""

    def _restore(self, checkpoint: dict[str, Any], agent: Agent, env: Any) -> None:
        agent.load_state_dict(checkpoint["agent"])
        agent.load_replay_state_dict(torch.load(self.dir.replay_path, map_location="cpu", weights_only=True))
        torch.set_rng_state(checkpoint["torch_rng"])
        _restore_env_rng(env, checkpoint["env_rng"])
        self._restore_progress(checkpoint)

    # -- checkpoints ----------------------------------------------------------------------------
    def _head(self, wall_s: float) -> dict[str, Any]:
        """The keys latest.pt and best.pt start with: the env's spec (observation kind, shape and dtype,
        action size and bounds), so a policy can be rebuilt without its env."""
        return self._checkpoint_head(wall_s, **self.spec.to_dict())

    def _save_latest(self, agent: Agent, env: Any, wall_s: float) -> None:
        atomic_torch_save(agent.replay_state_dict(), self.dir.replay_path)
        atomic_torch_save(
            {
                **self._head(wall_s),
                "evals": self._eval_history(),
                "agent": agent.state_dict(),
                "policy": agent.policy_state(),
                "torch_rng": torch.get_rng_state(),
                "env_rng": _env_rng_state(env),
            },
            self.dir.latest_path,
        )

    def _save_best(self, agent: Agent, wall_s: float, evaluation: dict[str, float]) -> None:
        atomic_torch_save(
            {**self._head(wall_s), "eval": evaluation, "policy": agent.policy_state()},
            self.dir.best_path,
        )

    # -- the loop --------------------------------------------------------------------------------
    def run(self) -> dict[str, Any]:
        cfg = self.config
        adapted = make_env(cfg)  # a bad env id or space fails before the run directory is touched
        env, eval_env = adapted.env, None
        try:
            checkpoint = self._begin()
        except BaseException:
            env.close()
            raise
        agent_rng = np.random.default_rng(np.random.SeedSequence(cfg.run.seed).spawn(1)[0])
        try:
            self.spec = adapted.spec
            agent = make_agent(cfg, self.spec, agent_rng)
            first_reset_seed: int | None = cfg.run.seed
            if checkpoint is not None:
                self._restore(checkpoint, agent, env)
                first_reset_seed = None
            self._start_clock()
            with self.stop_flag:
                while not self._budget_spent():
                    if self.stop_flag():
                        self.stopped = True
                        break
                    record = self._train_episode(agent, env, first_reset_seed)
                    first_reset_seed = None
                    if record is None:
                        self.stopped = True
                        break
                    if self._evaluation_due():
                        eval_env = eval_env or make_env(cfg, evaluation=True).env
                        record.update(self._evaluate(agent, eval_env, self.wall()))
                    self._log_episode(record)
                    if self._checkpoint_due():
                        self._save_latest(agent, env, self.wall())
                        self.last_checkpoint = time.perf_counter()
                final_eval = {}
                if self._final_evaluation_due():
                    eval_env = eval_env or make_env(cfg, evaluation=True).env
                    final_eval = self._evaluate(agent, eval_env, self.wall())
            self._save_latest(agent, env, self.wall())
            return self._finish(
                final_eval,
                cfg.agent.ac,
                diagnostics={k: self.csv.column(k) for k in self.csv.columns if k.startswith("dual/")},
            )
        finally:
            env.close()
            if eval_env is not None:
                eval_env.close()

    def _train_episode(self, agent: Agent, env: Any, reset_seed: int | None) -> dict[str, Any] | None:
        obs, _ = env.reset(seed=reset_seed)
        agent.begin_episode(obs)
        start_value = agent.start_value(obs) if hasattr(agent, "start_value") else math.nan
        discounted, discount = 0.0, 1.0
        episode_return, length, success, toppled = 0.0, 0, False, False
        losses: list[dict[str, float]] = []
        step_diagnostics: list[dict[str, float]] = []
        measured: dict[str, float] = {}
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
            discounted += discount * float(reward)
            discount *= self.config.agent.gamma
            step_losses = agent.update_after_step()
            if step_losses:
                losses.append(step_losses)
            obs = next_obs
            if terminated or truncated:
                success = episode_success(info, terminated, truncated, self.config.env.success)
                toppled = bool(info.get("toppled", False))
                measured = env_diagnostics(info)
                break
        episode_losses = agent.update_after_episode()
        if episode_losses:
            losses.append(episode_losses)
        record = self._new_record(episode_return, length, success, toppled)
        record.update(mean_dicts(losses))
        record.update(mean_dicts(step_diagnostics))
        record.update(agent.episode_diagnostics())
        record.update(measured)
        # Overestimation in sight: the critic's value of the start state beside the discounted return earned.
        record["charts/start_value"] = start_value
        record["charts/discounted_return"] = discounted
        return record

    def _evaluate(self, agent: Agent, eval_env: Any, wall_s: float) -> dict[str, float]:
        cfg = self.config
        result = evaluate(agent, eval_env, cfg.run.eval_episodes, success_rule=cfg.env.success,
                          gamma=cfg.agent.gamma)
        if self._record_evaluation(result):
            self._save_best(agent, wall_s, result)
        return result


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
    return _Trainer(resolve_algo(config), Path(run_dir), resume, on_episode, should_stop, command).run()
