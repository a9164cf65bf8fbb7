"""The `dualsys` command: one Typer app, one module per command group.

Each group module stays thin: it parses options, calls a library function and prints.
"""

from __future__ import annotations

import typer

from dualsys_cli import (
    bench,
    deploy,
    diagnose,
    env,
    experiment,
    experiments_jobs,
    jobs,
    registry_cmd,
    serve,
    sim2real_cmd,
    train,
)

app = typer.Typer(
    name="dualsys",
    help="Dual-system (model-based + model-free) robot motor learning: IM2C and I2A.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
app.add_typer(env.app, name="env")
app.add_typer(bench.app, name="bench")
app.add_typer(diagnose.app, name="diagnose")
app.command("train")(train.train_command)
app.add_typer(experiment.app, name="experiment")
app.command("serve")(serve.serve_command)
app.add_typer(jobs.app, name="jobs")
app.add_typer(experiments_jobs.app, name="experiments")
app.add_typer(registry_cmd.app, name="registry")
app.command("export")(deploy.export_command)
app.command("eval")(deploy.eval_command)
app.command("pairs")(sim2real_cmd.pairs_command)
app.command("align")(sim2real_cmd.align_command)


if __name__ == "__main__":  # pragma: no cover
    app()
