"""The `train` kind: `core.runs.trainer.train` on the spec's resolved config (same as `dualsys train`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel

from service.errors import SpecRejected
from service.execution.job_kinds.base import JobContext, Submission
from service.schemas.specs import TrainSpec

if TYPE_CHECKING:
    from registry import PolicyRegistry

LATEST_CHECKPOINT = Path("checkpoints") / "latest.pt"


def prepare_train(spec: BaseModel, registry: PolicyRegistry) -> Submission:
    """Resolve the config now, so a bad combination is a 422 and the job records what it ran."""
    assert isinstance(spec, TrainSpec)
    from core.config import ConfigError, check_config
    from core.runs.methods import resolve_algo

    try:
        config = resolve_algo(load_train_config(spec))
        check_config(config)
    except ConfigError as error:
        raise SpecRejected(f"spec: {error}", field="spec") from error
    return Submission(resolved={"config": config.to_dict()}, progress_total=config.run.episodes)


def run_train(context: JobContext) -> dict[str, Any]:
    spec = context.spec
    assert isinstance(spec, TrainSpec)
    if "cell" in context.resolved:
        return run_experiment_cell(context)
    from core.runs.trainer import train  # torch is imported by the worker, not by the API process

    config = resolved_train_config(context.resolved) or load_train_config(spec)
    resume = context.resume and (context.run_dir / LATEST_CHECKPOINT).is_file()
    summary = train(
        config,
        context.run_dir,
        resume=resume,
        on_episode=context.emit,
        should_stop=context.should_stop,
    )
    return dict(summary or {})


def load_train_config(spec: TrainSpec):  # type: ignore[no-untyped-def]
    """The run's Config: the profile (auto: by the task's observations), then `overrides`, then the named
    options (as `dualsys train`)."""
    from core.runs.profile_choice import load_run_config

    return load_run_config(spec.profile, spec.config_overrides())


def resolved_train_config(resolved: dict[str, Any]):  # type: ignore[no-untyped-def]
    """The config `prepare_train` resolved at submission (what the job records it ran), or None for a job
    stored without one. Training on it, not on the spec again, keeps the run equal to its record and spares
    the worker a second env build for `profile: auto`."""
    if "config" not in resolved:
        return None
    from core.config import Config
    from core.dual.readings import upgrade_stored

    return Config.from_dict(upgrade_stored(resolved["config"]))


def run_experiment_cell(context: JobContext) -> dict[str, Any]:
    """A cell of an experiment (service/database/experiment_store.py): `core.experiments.run_cell` on the
    cell's own resolved config, in the cell's folder; it skips a done cell, resumes a partial one, else
    starts."""
    from core.experiments import Cell, run_cell

    cell = context.resolved["cell"]
    summary = run_cell(
        Cell(
            experiment=cell["experiment"],
            label=cell["label"],
            algo=cell["algo"],
            reward=cell["reward"],
            seed=int(cell["seed"]),
            run_dir=context.run_dir,
            config=context.resolved["config"],
        ),
        should_stop=context.should_stop,
        on_episode=context.emit,
        command=f"dualsys experiments (service job {context.job_id}: {cell['experiment']} {cell['key']})",
    )
    return dict(summary or {})
