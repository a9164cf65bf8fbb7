"""`dualsys env ...`: look at the NicoGrasp scene and check that the task is solvable."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from dualsys_cli.errors import user_errors

app = typer.Typer(
    help="The NicoGrasp simulation: pictures and a scripted-oracle check.", no_args_is_help=True
)


@app.command("show")
def show(
    out: Path = typer.Option(Path("scene.png"), "--out", "-o", help="PNG file to write."),
    seed: int = typer.Option(0, help="Seed of the glass position."),
    hand: str = typer.Option("auto", help="Hand mode: auto | learned."),
) -> None:
    """Save a picture: the scene from a three-quarter view beside the 64×32 observation of both domains."""
    with user_errors():
        from core.envs.scene_picture import scene_picture

        picture = scene_picture(seed=seed, hand=hand)
        out.parent.mkdir(parents=True, exist_ok=True)
        picture.save(out)
    typer.echo(f"wrote {out} ({picture.width}x{picture.height})")


@app.command("check")
def check(
    episodes: int = typer.Option(100, min=1, help="Number of seeded oracle episodes."),
    hand: str = typer.Option("auto", help="Hand mode: auto | learned."),
    reward: str = typer.Option("dense", help="Reward mode: dense | sparse."),
    seed: int = typer.Option(0, help="Seed of the first episode (episode i uses seed + i)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Run the scripted oracle (reads `info`, turns to the glass, closes if the hand is learned)."""
    with user_errors():
        from core.envs import NicoGraspEnv, run_oracle

        env = NicoGraspEnv(hand=hand, reward_mode=reward)
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
