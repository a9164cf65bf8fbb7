"""`dualsys env ...`: look at the NicoGrasp scene and check that the task is solvable."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from dualsys_cli.errors import user_errors

app = typer.Typer(
    help="The NicoGrasp simulation: pictures, a scripted-oracle check and task-level calibration.",
    no_args_is_help=True,
)

LEVEL_HELP = "Task level: released | paper | hard | seen (docs/environment.md)."
HAND_HELP = "Hand mode: auto | learned (default: the level's hand; released: auto, the others: learned)."


@app.command("show")
def show(
    out: Path = typer.Option(Path("scene.png"), "--out", "-o", help="PNG file to write."),
    seed: int = typer.Option(0, help="Seed of the glass position."),
    level: str = typer.Option("released", help=LEVEL_HELP),
    hand: str | None = typer.Option(None, help=HAND_HELP),
) -> None:
    """Save a picture: the level's scene and start pose from a three-quarter view beside the 64×32
    observation of both domains."""
    with user_errors():
        from core.envs.scene_picture import scene_picture

        picture = scene_picture(seed=seed, hand=hand, level=level)
        out.parent.mkdir(parents=True, exist_ok=True)
        picture.save(out)
    typer.echo(f"wrote {out} ({picture.width}x{picture.height})")


@app.command("check")
def check(
    episodes: int = typer.Option(100, min=1, help="Number of seeded oracle episodes."),
    level: str = typer.Option("released", help=LEVEL_HELP),
    hand: str | None = typer.Option(None, help=HAND_HELP),
    reward: str = typer.Option("dense", help="Reward mode: dense | sparse."),
    seed: int = typer.Option(0, help="Seed of the first episode (episode i uses seed + i)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Run the scripted oracle (reads `info`, turns to the glass, closes if the hand is learned)."""
    with user_errors():
        from core.envs import NicoGraspEnv, run_oracle

        env = NicoGraspEnv(level=level, hand=hand, reward_mode=reward)
        try:
            result = run_oracle(env, episodes, seed=seed)
        finally:
            env.close()
    if as_json:
        typer.echo(json.dumps(result))
    else:
        typer.echo(
            f"oracle success rate {result['oracle_success_rate']:.1%} over {episodes} episodes "
            f"({result['toppled']} toppled, {result['mean_steps']:.1f} steps per episode)"
        )


@app.command("calibrate")
def calibrate_level(
    level: str = typer.Option(None, help=LEVEL_HELP + " (NicoGrasp; default released)"),
    env: str = typer.Option(
        None, "--env", help="Calibrate another gymnasium task instead (random and constant actions)."
    ),
    env_kwargs: str = typer.Option(None, "--env-kwargs", help="gymnasium.make arguments of --env (YAML)."),
    success: str = typer.Option(
        "info", "--success", help="With --env: success is info['success'] (info) or termination (terminated)."
    ),
    reward: str = typer.Option("sparse", help="Reward mode: dense | sparse."),
    episodes: int = typer.Option(None, min=1, help="Seeded episodes per policy (NicoGrasp 100, --env 20)."),
    hand: str | None = typer.Option(None, help=HAND_HELP),
    seed: int = typer.Option(0, help="Seed of the first episode (episode i uses seed + i)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    with_constants: bool = typer.Option(
        False, "--all-constants", help="With --json, also list every constant action's rates."
    ),
) -> None:
    """Success and topple rates of the oracle, a uniform random policy and every constant action (shoulder
    −1..1 in steps of 0.1; with the learned hand each with close and with open), and the best constant. With
    --env: any gymnasium task's random and constant policies (success rate and mean return; no oracle)."""
    from rich.progress import Progress

    if env is not None and env != "dualsys/NicoGrasp-v0":
        _calibrate_task(env, env_kwargs, success, episodes or 20, seed, as_json, with_constants)
        return
    level = level or "released"
    episodes = episodes or 100
    with user_errors():
        from core.envs.calibration import calibrate, constant_count
        from core.task_levels import get_level

        resolved_hand = hand or get_level(level).hand
        total = 2 + constant_count(resolved_hand)
        with Progress(transient=True, console=_stderr_console()) as progress:
            task = progress.add_task(f"calibrating {level} ({reward})", total=total)
            result = calibrate(
                level,
                reward,
                episodes,
                hand=hand,
                seed=seed,
                on_policy_done=lambda name: progress.advance(task),
            )
    if not with_constants:
        result.pop("constants")
    if as_json:
        typer.echo(json.dumps(result))
        return
    typer.echo(f"level {level}, {reward} reward, hand {result['hand']}, {episodes} episodes per policy")
    for name in ("oracle", "random"):
        row = result[name]
        typer.echo(
            f"  {name:<14} success {row['success']:6.1%}  toppled {row['toppled']:6.1%}"
            f"  mean return {row['mean_return']:8.3f}"
        )
    best = result["best_constant"]
    typer.echo(
        f"  best constant  success {best['success']:6.1%}  toppled {best['toppled']:6.1%}"
        f"  mean return {best['mean_return']:8.3f}  action {best['action']}"
    )


def _calibrate_task(
    env_id: str,
    env_kwargs: str | None,
    success: str,
    episodes: int,
    seed: int,
    as_json: bool,
    constants: bool,
) -> None:
    from rich.progress import Progress

    with user_errors():
        from core.config import EnvConfig, coerce
        from core.envs.gym_env import make_env
        from core.envs.task_calibration import calibrate_task, constant_count

        if success not in ("info", "terminated"):
            raise ValueError(f"bad value for --success: {success!r} (choose from info, terminated)")
        kwargs = coerce(env_kwargs, dict, "--env-kwargs") if env_kwargs else {}
        config = EnvConfig(id=env_id, kwargs=kwargs, success=success)  # type: ignore[arg-type]
        probe = make_env(config)
        probe.env.close()
        with Progress(transient=True, console=_stderr_console()) as progress:
            total = 1 + constant_count(probe.spec.action_dim)
            task = progress.add_task(f"calibrating {env_id}", total=total)
            tick = lambda name: progress.advance(task)  # noqa: E731
            result = calibrate_task(config, episodes, seed, on_policy_done=tick)
    if not constants:
        result.pop("constants")
    if as_json:
        typer.echo(json.dumps(result))
        return
    typer.echo(f"{env_id}, {episodes} episodes per policy (success: {success})")
    for name, row in (("random", result["random"]), ("best constant", result["best_constant"])):
        action = f"  action {row['action']}" if "action" in row else ""
        rates = f"success {row['success']:6.1%}  mean return {row['mean_return']:9.2f}"
        typer.echo(f"  {name:<14} {rates}{action}")


@app.command("list")
def list_envs(
    contains: str = typer.Argument(None, help="Show only ids containing this text (case-insensitive)."),
) -> None:
    """The gymnasium ids `dualsys train --env` accepts here (dm_control ids need the dmc extra)."""
    from core.envs.gym_env import registered_ids

    ids = [env_id for env_id in registered_ids() if not contains or contains.lower() in env_id.lower()]
    for env_id in ids:
        typer.echo(env_id)


def _stderr_console():
    from rich.console import Console

    return Console(stderr=True)
