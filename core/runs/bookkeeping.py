"""The bookkeeping every training loop of a run directory shares, whatever trains the policy.

:class:`RunBookkeeping` is the base of ``core.runs.trainer``'s loop and of the Stable-Baselines3 peer
(``core.experiments.sb3_peer``), so both write the same run directory the same way. It owns:

* the run directory's set-up: a new run refuses a directory that already holds one; a resumed run must
  match its checkpoint's ``net``, ``env``, ``agent`` and ``dual`` sections and ``run.algo``; then
  config.yaml, a line in command.txt, torch's thread count and seed, and metrics.csv;
* the counters (episode, global step, wall clock including earlier sessions), the training returns and
  successes, the evaluation history and the best evaluation, and their restore from a checkpoint;
* the episode record (:data:`RECORD_KEYS`), its metrics.csv row, its TensorBoard scalars when
  ``run.tensorboard`` is set (:mod:`core.runs.tensorboard_log`) and the ``on_episode`` callback;
* when to evaluate, checkpoint and end (the budget; ``should_stop()`` or Ctrl-C through :class:`StopFlag`);
* summary.json and learning_curve.png.

The subclass owns the training itself, and what its checkpoints hold beyond the counters.
"""

from __future__ import annotations

import math
import shlex
import signal
import sys
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import Config, ConfigError, check_config, resolve_level_defaults
from core.dual.readings import upgrade_stored
from core.runs.cpu_isa import check_process
from core.runs.metrics import area_under_curve, final_performance
from core.runs.run_dir import CHECKPOINT_FORMAT, MetricsCSV, RunDirectory, RunDirectoryError, load_checkpoint
from core.runs.tensorboard_log import TensorBoardLog, require_tensorboard

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

RESUME_CHECKED_SECTIONS: tuple[str, ...] = ("net", "env", "agent", "dual")
"""Config sections a resumed run must share with its checkpoint (besides ``run.algo``)."""

EpisodeCallback = Callable[[dict[str, Any]], None]


def env_diagnostics(info: dict[str, Any]) -> dict[str, float]:
    """The env's own measures of the episode that just ended: ``info["episode_diagnostics"]`` on its last
    step, a dict of floats that goes into the episode's record as it is (e.g. ``dualsys/ThreeRegions-v0``'s
    ``env/noise_share``); empty when the env gives none."""
    return {str(key): float(value) for key, value in (info.get("episode_diagnostics") or {}).items()}


class StopFlag:
    """should_stop() or Ctrl-C; the SIGINT handler is installed only in the main thread."""

    def __init__(self, should_stop: Callable[[], bool] | None) -> None:
        self.should_stop = should_stop
        self.interrupted = False
        self._previous: Any = None

    def __enter__(self) -> StopFlag:
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


def mean_dicts(items: list[dict[str, float]]) -> dict[str, float]:
    """Per key, the mean of the values the dicts give it (a key counts only where present)."""
    sums: dict[str, float] = {}
    counts: dict[str, int] = {}
    for item in items:
        for key, value in item.items():
            sums[key] = sums.get(key, 0.0) + float(value)
            counts[key] = counts.get(key, 0) + 1
    return {key: sums[key] / counts[key] for key in sums}


class RunBookkeeping:
    """Counters, histories, files and schedules of one training run; see the module docstring.

    A subclass calls :meth:`_begin` first (it returns the checkpoint to resume from, if any), restores its
    own state and then :meth:`_restore_progress`, calls :meth:`_start_clock` before the first episode,
    makes each finished episode's record with :meth:`_new_record` and hands it to :meth:`_log_episode`,
    and ends with :meth:`_finish`. ``config`` is resolved (level defaults) and checked here.
    """

    def __init__(
        self,
        config: Config,
        run_dir: Path,
        resume: bool,
        on_episode: EpisodeCallback | None,
        should_stop: Callable[[], bool] | None,
        command: str | None,
    ) -> None:
        self.config = resolve_level_defaults(config)
        check_config(self.config)
        self.dir = RunDirectory(run_dir)
        self.resume = resume
        self.on_episode = on_episode
        self.stop_flag = StopFlag(should_stop)
        self.command = command if command is not None else shlex.join(sys.argv)
        self.episode = 0
        self.global_step = 0
        self.wall_offset = 0.0
        self.returns: list[float] = []
        self.successes: list[float] = []
        self.evals: list[tuple[int, float]] = []
        self.best: tuple[float, float] | None = None
        self.last_eval: dict[str, float] = {}
        self.stopped = False
        self.tensorboard: TensorBoardLog | None = None
        self.resumed_at_step: int | None = None
        self.cpu: dict[str, str] = {}
        """The kernels the run got (run.cpu_isa, torch's capability, the CPU), for summary.json."""

    # -- setup -----------------------------------------------------------------------------------
    def _check_checkpoint(self, checkpoint: Mapping[str, Any]) -> None:
        """Refuse a checkpoint this kind of run cannot resume (before its config is compared)."""

    def _begin(self) -> dict[str, Any] | None:
        """Set up the run directory, torch's threads and seed, and metrics.csv; the checkpoint to resume
        from (``None`` for a new run)."""
        checkpoint = None
        self.cpu = check_process(self.config.run.cpu_isa)  # a pinned run in an unpinned process stops here
        if self.config.run.tensorboard:
            require_tensorboard()
        if self.resume:
            checkpoint = load_checkpoint(self.dir.latest_path)
            self._check_checkpoint(checkpoint)
            saved = Config.from_dict(upgrade_stored(checkpoint["config"]))
            for section in RESUME_CHECKED_SECTIONS:
                if getattr(saved, section) != getattr(self.config, section):
                    raise ConfigError(
                        f"cannot resume {self.dir.root}: config section {section!r} differs "
                        "from the saved run"
                    )
            if saved.run.algo != self.config.run.algo:
                raise ConfigError(f"cannot resume {self.dir.root}: it was trained with {saved.run.algo!r}")
            if saved.run.cpu_isa != self.config.run.cpu_isa:
                raise ConfigError(
                    f"cannot resume {self.dir.root}: it ran with run.cpu_isa={saved.run.cpu_isa}, "
                    f"not {self.config.run.cpu_isa}"
                )
        elif self.dir.holds_run():
            raise RunDirectoryError(f"run directory {self.dir.root} already holds a run (resume it instead)")
        self.dir.create()
        self.dir.write_config(self.config)
        self.dir.append_command(self.command)
        torch.set_num_threads(max(1, self.config.run.num_threads))
        torch.manual_seed(self.config.run.seed)
        self.csv = MetricsCSV(self.dir.metrics_path)
        return checkpoint

    def _restore_progress(self, checkpoint: Mapping[str, Any]) -> None:
        """Counters, best evaluation and evaluation history from ``checkpoint``; metrics.csv loses the rows
        written after it, and its remaining rows give the returns and successes."""
        counters = checkpoint["counters"]
        self.episode = int(counters["episode"])
        self.global_step = int(counters["global_step"])
        self.wall_offset = float(counters["wall_s"])
        best = counters.get("best")
        self.best = (float(best[0]), float(best[1])) if best else None
        self.evals = [(int(e), float(s)) for e, s in checkpoint["evals"]]
        self.csv.truncate_after(self.episode)
        self.resumed_at_step = self.global_step
        self.returns = self.csv.column("charts/episodic_return")
        self.successes = self.csv.column("charts/success")

    # -- the clock -------------------------------------------------------------------------------
    def _start_clock(self) -> None:
        """This session's start: wall clock, steps per second and time-based checkpoints count from now."""
        self.start_time = time.perf_counter()
        self.start_step = self.global_step
        self.last_checkpoint = self.start_time

    def wall(self) -> float:
        """Seconds of training, this session's and the earlier ones' of a resumed run."""
        return self.wall_offset + time.perf_counter() - self.start_time

    def _steps_per_second(self) -> float:
        return (self.global_step - self.start_step) / max(time.perf_counter() - self.start_time, 1e-9)

    # -- checkpoints -----------------------------------------------------------------------------
    def _counters(self, wall_s: float) -> dict[str, Any]:
        return {
            "episode": self.episode,
            "global_step": self.global_step,
            "wall_s": wall_s,
            "best": list(self.best) if self.best else None,
        }

    def _checkpoint_head(self, wall_s: float, **fields: Any) -> dict[str, Any]:
        """The keys a checkpoint starts with: format, config, the subclass's ``fields``, counters."""
        return {
            "format": CHECKPOINT_FORMAT,
            "config": self.config.to_dict(),
            **fields,
            "counters": self._counters(wall_s),
        }

    def _eval_history(self) -> list[list[Any]]:
        """The evaluation history as a checkpoint stores it."""
        return [list(item) for item in self.evals]

    # -- schedules -------------------------------------------------------------------------------
    def _budget_spent(self) -> bool:
        """``run.episodes``, ``run.steps`` or ``run.max_wall_s`` reached (checked at episode boundaries)."""
        run = self.config.run
        return (
            (run.episodes is not None and self.episode >= run.episodes)
            or (run.steps is not None and self.global_step >= run.steps)
            or (run.max_wall_s is not None and self.wall() >= run.max_wall_s)
        )

    def _checkpoint_due(self) -> bool:
        """Every ``run.checkpoint_every`` episodes, or ``run.checkpoint_every_s`` s after the last one."""
        run = self.config.run
        since_last_s = time.perf_counter() - self.last_checkpoint
        by_episode = run.checkpoint_every > 0 and self.episode % run.checkpoint_every == 0
        by_time = run.checkpoint_every_s is not None and since_last_s >= run.checkpoint_every_s
        return by_episode or by_time

    def _evaluation_due(self) -> bool:
        """Every ``run.eval_every`` training episodes."""
        run = self.config.run
        return run.eval_every > 0 and self.episode % run.eval_every == 0

    def _final_evaluation_due(self) -> bool:
        """At the end of a run that was not stopped, unless its last episode was just evaluated."""
        return (
            not self.stopped
            and self.config.run.final_eval
            and (not self.evals or self.evals[-1][0] != self.episode)
        )

    # -- episodes and evaluations ----------------------------------------------------------------
    def _new_record(self, episode_return: float, length: int, success: bool, toppled: bool) -> dict[str, Any]:
        """Count a finished training episode; its record (:data:`RECORD_KEYS`, NaN where not known yet)."""
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
        return record

    def _log_episode(self, record: dict[str, Any]) -> None:
        """Add the timing keys, append the record to metrics.csv and hand a copy to ``on_episode``."""
        elapsed = time.perf_counter() - self.start_time
        record["time/wall_s"] = self.wall()
        record["charts/sps"] = (self.global_step - self.start_step) / max(elapsed, 1e-9)
        self.csv.append(record)
        if self.config.run.tensorboard:
            if self.tensorboard is None:  # opened at the first record: a resumed run's step is known by then
                purge = None if self.resumed_at_step is None else self.resumed_at_step + 1
                self.tensorboard = TensorBoardLog(self.dir.root, purge_from_step=purge)
            self.tensorboard.add(record)
        if self.on_episode is not None:
            self.on_episode(dict(record))

    def _record_evaluation(self, result: dict[str, float]) -> bool:
        """Add a greedy evaluation to the history; True when it is the best so far (success rate, then
        return), whose policy the subclass then saves."""
        self.last_eval = result
        self.evals.append((self.episode, result["eval/success_rate"]))
        score = (result["eval/success_rate"], result["eval/return"])
        if self.best is None or score > self.best:
            self.best = score
            return True
        return False

    # -- the end ---------------------------------------------------------------------------------
    def _summary(self, final_eval: dict[str, float], ac: str | None) -> dict[str, Any]:
        last_eval = final_eval or self.last_eval
        recent = self.successes[-100:]
        return {
            "run_dir": str(self.dir.root),
            "algo": self.config.run.algo,
            "ac": ac,
            "env": self.config.env.id,
            "reward": self.config.env.reward_label,
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
            "wall_s": self.wall(),
            "sps": self._steps_per_second(),
            "stopped": self.stopped,
            **self.cpu,
        }

    def _finish(
        self,
        final_eval: dict[str, float],
        ac: str | None,
        diagnostics: Mapping[str, list[float]] | None = None,
    ) -> dict[str, Any]:
        """Write summary.json (``ac``: the actor-update rule, if the method has ours) and
        learning_curve.png (with the ``dual/…`` ``diagnostics`` panel, if given); the summary."""
        cfg = self.config
        if self.tensorboard is not None:
            self.tensorboard.close()
            self.tensorboard = None
        summary = self._summary(final_eval, ac)
        self.dir.write_summary(summary)
        self.dir.write_learning_curve(
            self.returns,
            self.evals,
            cfg.run.smoothing_window,
            f"{cfg.run.algo} · {cfg.env.id} · {cfg.env.reward_label} reward · seed {cfg.run.seed}",
            diagnostics=diagnostics,
        )
        return summary
