"""`dualsys diagnose ...`: look inside a trained run (what the dual-system parts see), and check that each
dual-system mechanism does its job on a controlled problem."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from dualsys_cli.errors import user_errors

app = typer.Typer(help="Diagnostics of the dual-system parts.", no_args_is_help=True)


@app.command("mechanisms")
def mechanisms(
    profile: str = typer.Option("default", help="Profile whose dual section is checked: default or paper."),
    quick: bool = typer.Option(False, "--quick", help="Smaller sizes of the same checks (the tests' sizes)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """The six mechanism checks (docs/dual-system.md, "Mechanisms"): world models, reliability, intrinsic
    reward, planner, regions, imagination."""
    with user_errors():
        from core.config import PROFILES

        if profile not in PROFILES:
            raise ValueError(f"unknown profile {profile!r} (choose from {', '.join(sorted(PROFILES))})")
        from core.dual.checks.runner import GOALS, run_mechanism_checks

        result = run_mechanism_checks(profile, quick=quick)
    if as_json:
        typer.echo(json.dumps(result))
        return
    typer.echo(f"profile {result['profile']}")
    for check, goal in GOALS.items():
        typer.echo(f"  {check:<12} {json.dumps(result[check])}")
        typer.echo(f"  {'':<12} goal: {goal}")


@app.command("regions")
def regions(
    policy: Path = typer.Argument(..., help="Run directory or checkpoint file."),
    episodes: int = typer.Option(40, min=1, help="Uniform-random episodes whose states are encoded."),
    e_max: str = typer.Option("6,3,1.5,0.75,0.375", help="Comma-separated e_max values to count nodes for."),
    seed: int = typer.Option(0, help="Seed of the episodes."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Latent distances of the run's encoder and how many ITM regions each e_max would make of them."""
    with user_errors():
        try:
            values = [float(v) for v in e_max.split(",") if v.strip()]
        except ValueError:
            raise ValueError(f"--e-max must be comma-separated numbers, got {e_max!r}") from None
        if not values or min(values) <= 0:
            raise ValueError(f"--e-max values must be > 0, got {e_max!r}")
        from core.runs.region_scale import region_scale

        result = region_scale(policy, episodes=episodes, e_max_values=values, seed=seed)
    if as_json:
        typer.echo(json.dumps(result))
        return
    typer.echo(f"{result['states']} states of level {result['level']}, ITM distance {result['itm_distance']}")
    for key in ("latent_norm", "consecutive_distance", "pairwise_distance"):
        q = result[key]
        typer.echo(f"  {key:<22} 5% {q['q05']:.3g}   median {q['q50']:.3g}   95% {q['q95']:.3g}")
    for value, nodes in result["nodes"].items():
        mark = "  (configured)" if float(value) == result["configured_e_max"] else ""
        typer.echo(f"  e_max {value:>6}: {nodes} nodes{mark}")
