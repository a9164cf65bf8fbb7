"""`dualsys bench ...`: benchmarks that print JSON figures (see bench/). Never assertions."""

from __future__ import annotations

import json

import typer

app = typer.Typer(help="Benchmarks: each prints JSON figures measured in the same run.", no_args_is_help=True)


def _emit(result: dict, as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps(result))
    else:
        for key, value in result.items():
            typer.echo(f"{key}: {value}")


@app.command("env")
def bench_env(
    seconds: float = typer.Option(5.0, help="Wall-clock seconds per measurement."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Env steps per second under random actions, beside the bare-PyBullet floor."""
    from bench.env_speed import measure

    _emit(measure(seconds=seconds), as_json)
