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

LEVEL_HELP = "Task level: released | paper | hard (docs/environment.md)."
HAND_HELP = "Hand mode: auto | learned (default: the level's hand; released: auto, paper and hard: learned)."


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
    level: str = typer.Option(..., help=LEVEL_HELP),
    reward: str = typer.Option("sparse", help="Reward mode: dense | sparse."),
    episodes: int = typer.Option(100, min=1, help="Seeded episodes per policy (the same positions for all)."),
    hand: str | None = typer.Option(None, help=HAND_HELP),
    seed: int = typer.Option(0, help="Seed of the first episode (episode i uses seed + i)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
    with_constants: bool = typer.Option(
        False, "--all-constants", help="With --json, also list every constant action's rates."
    ),
) -> None:
    """Success and topple rates of the oracle, a uniform random policy and every constant action (shoulder
    −1..1 in steps of 0.1; with the learned hand each with close and with open), and the best constant."""
    from rich.progress import Progress

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
        typer.echo(f"  {name:<14} success {row['success']:6.1%}  toppled {row['toppled']:6.1%}")
    best = result["best_constant"]
    typer.echo(
        f"  best constant  success {best['success']:6.1%}  toppled {best['toppled']:6.1%}"
        f"  action {best['action']}"
    )


def _stderr_console():
    from rich.console import Console

    return Console(stderr=True)
