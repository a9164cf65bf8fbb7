"""`dualsys train`: train a method on NicoGrasp or any gymnasium task into a run directory (parse, call
runs.trainer.train, print).

Config precedence: ``--profile`` → ``--config FILE`` → ``--set key=value`` (repeatable) → the explicit options
(``--algo``, ``--ac``, ``--env``, ``--reward``, ``--seed``, ``--episodes``, ``--steps``, ``--minutes``).
``--resume DIR`` starts from DIR's saved config.yaml instead of the profile and continues the run in DIR.
"""

from __future__ import annotations

import json
import math
import shlex
import sys
import time
from collections import deque
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from dualsys_cli.errors import user_errors

DEFAULT_RUNS_DIR = Path("dualsys-runs")
"""Where runs go without --out (embedded default)."""


def default_run_dir(algo: str, reward: str, root: Path = DEFAULT_RUNS_DIR) -> Path:
    """``dualsys-runs/<algo>-<reward>-<timestamp>`` (suffixed if it exists)."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    candidate = root / f"{algo}-{reward}-{stamp}"
    index = 1
    while candidate.exists():
        index += 1
        candidate = root / f"{algo}-{reward}-{stamp}-{index}"
    return candidate


def _run_name(config: Any) -> str:
    """NicoGrasp's reward mode, or another task's id made folder-safe (``dm_control/x``: ``dm_control-x``)."""
    if config.env.reward_label != "task":
        return config.env.reward_mode
    return config.env.id.replace("/", "-").replace(":", "-")


def build_config(
    *,
    profile: str,
    config_file: Path | None,
    overrides: list[str],
    resume: Path | None,
    algo: str | None,
    ac: str | None,
    reward: str | None,
    env: str | None = None,
    seed: int | None,
    episodes: int | None,
    steps: int | None,
    minutes: float | None,
) -> Any:
    """Resolve the run's Config from the options (see the module docstring)."""
    from core.config import Config, ConfigError, read_config_file, set_value
    from core.runs.profile_choice import load_run_config

    if resume is not None:
        saved = resume / "config.yaml"
        if not saved.is_file():
            raise ConfigError(f"cannot resume {resume}: no config.yaml (not a dualsys run directory)")
        from core.dual.readings import upgrade_stored

        config = Config.from_dict(upgrade_stored(read_config_file(saved)))
        if config_file is not None:
            config = Config.from_dict(read_config_file(config_file), base=config)
        for item in overrides:
            key, sep, raw = item.partition("=")
            if not sep:
                raise ConfigError(f"override {item!r} is not of the form section.key=value")
            set_value(config, key.strip(), raw.strip())
    else:
        config = load_run_config(profile, overrides, config_file, env_id=env)
    if algo is not None:
        config.run.algo = algo
    if ac is not None:
        set_value(config, "agent.ac", ac)
    if env is not None:
        set_value(config, "env.id", env)
    if reward is not None:
        set_value(config, "env.reward_mode", reward)
    if seed is not None:
        config.run.seed = seed
    if episodes is not None:
        config.run.episodes = episodes
    if steps is not None:
        config.run.steps = steps
        if episodes is None:
            config.run.episodes = None
    if minutes is not None:
        config.run.max_wall_s = minutes * 60.0
        if episodes is None and steps is None:
            config.run.episodes = None
    return config


class _ProgressView:
    """Rich progress bar fed by the trainer's on_episode records."""

    def __init__(self, console: Console, config: Any) -> None:
        run = config.run
        if run.episodes is not None:
            self.unit, total = "episode", run.episodes
        elif run.steps is not None:
            self.unit, total = "global_step", run.steps
        else:
            self.unit, total = "time/wall_s", int(run.max_wall_s or 0)
        self.recent_success: deque[float] = deque(maxlen=100)
        self.recent_return: deque[float] = deque(maxlen=100)
        self.progress = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            TextColumn("{task.fields[stats]}"),
            console=console,
            transient=False,
        )
        self.task = self.progress.add_task(f"{run.algo} · {_run_name(config)}", total=total, stats="")

    def __call__(self, record: dict[str, Any]) -> None:
        self.recent_success.append(float(record["charts/success"]))
        self.recent_return.append(float(record["charts/episodic_return"]))
        stats = (
            f"ep {record['episode']} · {record['charts/sps']:.0f} steps/s · "
            f"success(100) {sum(self.recent_success) / len(self.recent_success):.0%} · "
            f"reward(100) {sum(self.recent_return) / len(self.recent_return):+.2f}"
        )
        evaluated = record.get("eval/success_rate")
        if evaluated is not None and not math.isnan(evaluated):
            stats += f" · eval {evaluated:.0%}"
        self.progress.update(self.task, completed=int(record[self.unit]), stats=stats)


def _summary_table(summary: dict[str, Any]) -> Table:
    table = Table(title="training summary", show_header=False)
    for key in (
        "run_dir",
        "algo",
        "reward",
        "seed",
        "episodes",
        "steps",
        "final_perf",
        "auc",
        "success_rate",
        "best_success_rate",
        "train_success_rate_last100",
        "wall_s",
        "sps",
    ):
        value = summary.get(key)
        text = f"{value:.3f}" if isinstance(value, float) else str(value)
        table.add_row(key, text)
    return table


def train_command(
    algo: str = typer.Option(
        None, "--algo", help="Method: ddpg, cacla, td3, sac (model-free), im2c, i2a, cmc, la-imagination, "
        "mve, rnd, or any registered method."
    ),
    env: str = typer.Option(
        None, "--env", help="Gymnasium id (default dualsys/NicoGrasp-v0; `dualsys env list` shows the ids)."
    ),
    reward: str = typer.Option(None, "--reward", help="NicoGrasp's reward: dense | sparse."),
    seed: int = typer.Option(None, "--seed", help="Run seed (default: the profile's, 0)."),
    episodes: int = typer.Option(None, "--episodes", min=1, help="Training episodes."),
    steps: int = typer.Option(None, "--steps", min=1, help="Training environment steps."),
    minutes: float = typer.Option(None, "--minutes", min=0.0, help="Wall-clock training budget."),
    out: Path = typer.Option(
        None, "--out", help="Run directory (default: ./dualsys-runs/<algo>-<reward>-<time>)."
    ),
    profile: str = typer.Option(
        "auto", "--profile",
        help="Config profile: default | paper | vector; auto: vector for a task with vector observations "
        "(the textbook networks), default otherwise.",
    ),
    overrides: list[str] = typer.Option(None, "--set", help="Override a config value: section.key=value."),
    config_file: Path = typer.Option(None, "--config", help="YAML/JSON file of config sections."),
    resume: Path = typer.Option(None, "--resume", help="Continue the run in this directory."),
    ac: str = typer.Option(None, "--ac", help="The learner under a dual-system method (or rnd): "
                            "ddpg | cacla | td3 | sac."),
    tensorboard: bool = typer.Option(
        None,
        "--tensorboard/--no-tensorboard",
        help="Write TensorBoard event files into the run directory (run.tensorboard; "
        "open them with: tensorboard --logdir dualsys-runs).",
    ),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON summary line."),
) -> None:
    """Train a policy (the vision-based grasp by default, or any gymnasium task with --env); Ctrl-C leaves a
    resumable checkpoint."""
    from core.runs.trainer import train

    switch = [] if tensorboard is None else [f"run.tensorboard={str(tensorboard).lower()}"]
    with user_errors():
        config = build_config(
            profile=profile,
            config_file=config_file,
            overrides=[*(overrides or []), *switch],
            resume=resume,
            algo=algo,
            ac=ac,
            reward=reward,
            env=env,
            seed=seed,
            episodes=episodes,
            steps=steps,
            minutes=minutes,
        )
        from core.config import check_config
        from core.envs.gym_env import make_env
        from core.runs.cpu_isa import ensure_process
        from core.runs.methods import resolve_algo

        config = resolve_algo(config)
        check_config(config)
        # run.cpu_isa: re-execute this command with the kernels pinned (torch and NumPy start anew there)
        ensure_process(config.run.cpu_isa)
        console = Console(stderr=True)
        adapted = make_env(config.env)  # an unknown id or unsupported space fails here, before any folder
        adapted.env.close()
        for note in adapted.notes:
            console.print(f"[dim]env: {note}[/dim]")
        run_dir = resume or out or default_run_dir(config.run.algo, _run_name(config))
        from core.runs.run_dir import RunDirectory, RunDirectoryError

        if resume is None and RunDirectory(run_dir).holds_run():
            raise RunDirectoryError(f"run directory {run_dir} already holds a run (resume it instead)")
        view = _ProgressView(console, config)
        with view.progress:
            summary = train(
                config,
                run_dir,
                resume=resume is not None,
                on_episode=view,
                command=shlex.join(["dualsys", *sys.argv[1:]]),
            )
    if as_json:
        keys = ("run_dir", "episodes", "steps", "final_perf", "auc", "success_rate", "wall_s")
        typer.echo(json.dumps({key: _json_value(summary[key]) for key in keys}))
    else:
        Console().print(_summary_table(summary))
        run_path = Path(summary["run_dir"])
        typer.echo(f"policy:         {run_path / 'checkpoints' / 'best.pt'} (latest: checkpoints/latest.pt)")
        typer.echo(f"metrics:        {run_path / 'metrics.csv'} (summary: summary.json)")
        typer.echo(f"learning curve: {run_path / 'learning_curve.png'}")
        if summary.get("stopped"):
            typer.echo(f"stopped; continue with: dualsys train --resume {summary['run_dir']}")


def _json_value(value: Any) -> Any:
    return None if isinstance(value, float) and not math.isfinite(value) else value
