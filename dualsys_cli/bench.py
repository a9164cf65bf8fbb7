"""`dualsys bench ...`: benchmarks that print JSON figures (see bench/). Never assertions."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from dualsys_cli.errors import user_errors

app = typer.Typer(help="Benchmarks: each prints JSON figures measured in the same run.", no_args_is_help=True)


def _emit(result: dict, as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps(result))
    else:
        for key, value in result.items():
            typer.echo(f"{key}: {value}")


@app.command("env")
def bench_env(
    seconds: float = typer.Option(6.0, help="Wall-clock seconds per measurement."),
    level: str = typer.Option("released", help="Task level: released | paper | hard."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Env steps per second under random actions, beside the bare-PyBullet floor of the same scene."""
    with user_errors():
        from bench.env_speed import measure
        from core.task_levels import get_level

        get_level(level)
        result = measure(seconds=seconds, level=level)
    _emit(result, as_json)


@app.command("modelbank")
def bench_modelbank(
    batch: int = typer.Option(32, min=1, help="(node, sample) pairs per predict + update call."),
    repeats: int = typer.Option(200, min=1, help="Timed calls per node count (median reported)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """World-model bank predict + update time for 2, 50 and 500 nodes (goal: 500 ≤ 2× the cost of 2)."""
    from bench.modelbank_speed import measure

    _emit(measure(batch=batch, repeats=repeats), as_json)


@app.command("plan")
def bench_plan(
    latent_dim: int = typer.Option(32, min=1, help="Latent size (the default profile's is 32)."),
    action_dim: int = typer.Option(2, min=1, help="Action size."),
    repeats: int = typer.Option(200, min=1, help="Timed decisions per reading (median reported)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Milliseconds per model-based decision with the aiming planner's pull against the same plan without."""
    from bench.plan_speed import measure

    _emit(measure(latent_dim=latent_dim, action_dim=action_dim, repeats=repeats), as_json)


@app.command("train")
def bench_train(
    algos: str = typer.Option(
        "ddpg,sb3-ddpg",
        help="Comma-separated methods: any --algo "
        "(ddpg, cacla, td3, sac, im2c, i2a, mve, cmc, la-imagination), sb3-ddpg, sb3-td3, sb3-sac.",
    ),
    batch: int = typer.Option(None, min=1, help="Minibatch size (default: the default profile's)."),
    steps: int = typer.Option(300, min=10, help="Timed training steps per method and round."),
    rounds: int = typer.Option(2, min=1, help="Alternating rounds; the median is reported."),
    env: str = typer.Option(None, "--env", help="Gymnasium id (default: NicoGrasp)."),
    profile: str = typer.Option("default", help="Config profile of our methods (default, vector, paper)."),
    settings: list[str] = typer.Option(
        [],
        "--set",
        help="KEY=VALUE config override for our methods, repeatable (e.g. --set agent.ac=sac "
        "--set dual.planner=progress).",
    ),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Milliseconds per training step (env step + one update): dualsys vs Stable-Baselines3 DDPG."""
    from bench.train_speed import measure

    with user_errors():
        result = measure(
            algos=tuple(a.strip() for a in algos.split(",") if a.strip()),
            batch=batch,
            steps=steps,
            rounds=rounds,
            env=env,
            profile=profile,
            settings=tuple(settings),
        )
    _emit(result, as_json)


@app.command("experiment")
def bench_experiment(
    file: Path = typer.Option(None, "--file", help="Experiment file (default: experiments/smoke.yaml)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Wall-clock time of the smoke experiment on 1 and on 2 local workers (goal: speedup ≥ 1.7)."""
    from bench.experiment_speed import SMOKE, measure

    with user_errors():
        result = measure(file or SMOKE)
    _emit(result, as_json)


@app.command("onnx")
def bench_onnx(
    policy: str = typer.Option(None, "--policy", help="Run dir or checkpoint (default: untrained net)."),
    repeats: int = typer.Option(2000, min=1, help="Timed calls at batch 1 (median reported)."),
    threads: int = typer.Option(1, min=1, help="Threads for both onnxruntime and PyTorch."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Per-image policy latency, onnxruntime vs PyTorch, batch 1 and 64 (goal: ≤ 1 ms at batch 1)."""
    from bench.onnx_speed import measure

    with user_errors():
        result = measure(policy=policy, repeats=repeats, threads=threads)
    _emit(result, as_json)


@app.command("service")
def bench_service(
    seconds: float = typer.Option(10.0, min=1.0, help="Seconds of load."),
    clients: int = typer.Option(20, min=1, max=200, help="Concurrent HTTP clients."),
    api_processes: str = typer.Option(
        "1", "--api-processes", help="Comma-separated API-process counts, one service each (e.g. 1,2)."
    ),
    jobs_in_table: int = typer.Option(10_000, min=1, help="Jobs in the table while GET /jobs is timed."),
    database: str = typer.Option(
        "sqlite", "--database", help="Comma-separated: sqlite, postgresql (a throwaway local server)."
    ),
    repeat: int = typer.Option(1, "--repeat", min=1, max=20, help="Runs of each configuration (medians)."),
    profile: Path = typer.Option(
        None, "--profile", help="Folder for py-spy recordings of the service processes during the load."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """p50/p99 of GET and POST /jobs under concurrent clients while a training job runs (goal p99 < 50 ms),
    on SQLite and/or PostgreSQL, with medians over repeats."""
    from bench.service_speed import measure

    with user_errors():
        counts = tuple(int(n) for n in api_processes.split(",") if n.strip()) if api_processes else ()
        if not counts or any(n < 1 or n > 32 for n in counts):
            raise ValueError(f"--api-processes wants counts from 1 to 32 such as 1,2 (got {api_processes!r})")
        databases = tuple(d.strip() for d in database.split(",") if d.strip())
        if not databases or any(d not in ("sqlite", "postgresql") for d in databases):
            raise ValueError(f"--database wants sqlite, postgresql or both (got {database!r})")
        result = measure(
            seconds=seconds,
            clients=clients,
            api_processes=counts,
            jobs_in_table=jobs_in_table,
            databases=databases,
            repeat=repeat,
            profile_dir=profile,
        )
    _emit(result, as_json)


@app.command("dashboard")
def bench_dashboard(
    loads: int = typer.Option(20, min=1, help="Timed loads per page (p50/p90 reported)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """The web dashboard's jobs page with 1 000 jobs: server render time (goal p50 < 100 ms) and first-load
    bytes (goal < 500 kB)."""
    from bench.dashboard_speed import measure

    with user_errors():
        result = measure(loads=loads)
    _emit(result, as_json)
