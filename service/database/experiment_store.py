"""Experiments as jobs: an experiment file (`core.experiments`) queued as one `train` job per cell.

`create_experiment` validates the file with the library (`load_experiment`: every cell's config is
resolved and checked), expands its cells under `<artifacts>/experiments/<id>/` and, in one write
transaction, inserts the experiment row and one queued `train` job per cell whose run directory is the
cell's folder (`experiments/<id>/<name>/<label>/<reward>/seed-<s>`) and whose `resolved` holds the
cell (config, label, algo, reward, seed). The worker runs such a job with `core.experiments.run_cell`
(skip when done, resume from `latest.pt`, else start), so a cell recovers like any job, and the
experiment folder is exactly what `dualsys experiment run` writes: `build_report` reads it unchanged.

The supervisor's claim lets at most `workers` cells of one experiment run at once
(`job_store.claim_next_job`). Cancelling an experiment cancels its unfinished cells.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from sqlalchemy import delete, func, select

from registry.artifact_store import ArtifactStore
from registry.database import Database
from service.database import job_store
from service.database.models import FINISHED_STATUSES, Experiment, Job, JobArtifact, JobMetric
from service.errors import JobConflict, JobNotFound, SpecRejected

EXPERIMENTS_AREA = "experiments"
_FIELD = re.compile(r"^(?:bad value for|unknown key|missing key) '?([A-Za-z0-9_.\[\]]+)'?")


class ExperimentNotFound(JobNotFound):
    """No experiment with that id (404)."""


@dataclass
class ExperimentState:
    """An experiment row, its cells (job rows) and the counts by status."""

    experiment: Experiment
    jobs: list[Any]
    counts: dict[str, int]

    @property
    def status(self) -> str:
        """queued | running | succeeded (every cell) | failed (a cell failed, none left) | cancelled."""
        counts, total = self.counts, len(self.jobs)
        if counts.get("running"):
            return "running"
        if counts.get("queued"):
            return "running" if counts.get("succeeded") or counts.get("failed") else "queued"
        if counts.get("succeeded", 0) == total:
            return "succeeded"
        return "failed" if counts.get("failed") else "cancelled"


def load_spec(content: str) -> Any:
    """The validated ExperimentSpec of a file's text; SpecRejected (422) naming the key otherwise."""
    from core.config import ConfigError
    from core.experiments import load_experiment

    if not content.strip():
        raise SpecRejected("content: the experiment file is empty", field="content")
    try:  # parsed here: given a string, load_experiment would also take a one-line path to a file
        data = yaml.safe_load(content)
    except yaml.YAMLError as error:
        raise SpecRejected(f"content: not YAML ({str(error).splitlines()[0]})", field="content") from None
    if not isinstance(data, dict):
        raise SpecRejected("content: an experiment file is a YAML mapping of keys", field="content")
    try:
        return load_experiment(data)
    except ConfigError as error:  # ExperimentError is a ConfigError; resolving a cell raises either
        message = str(error).splitlines()[0]
        key = _FIELD.match(message)
        field = f"content.{key.group(1)}" if key else "content"
        raise SpecRejected(f"content: {message}", field=field) from error


def create_experiment(database: Database, store: ArtifactStore, *, content: str, workers: int) -> int:
    """Validate the file, write its folder's experiment.yaml, queue one train job per cell; its id."""
    from core.experiments import expand_cells
    from core.experiments.cells import EXPERIMENT_FILE
    from core.runs.run_dir import atomic_write_text

    spec = load_spec(content)
    with database.write() as session:
        experiment = Experiment(name=spec.name, spec=spec.to_dict(), workers=workers)
        session.add(experiment)
        session.flush()
        area = store.confine(f"{EXPERIMENTS_AREA}/{experiment.id}")
        cells = expand_cells(spec, area)
        experiment.directory = f"{EXPERIMENTS_AREA}/{experiment.id}/{spec.name}"
        folder = store.confine(experiment.directory)
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(folder / EXPERIMENT_FILE, spec.to_yaml())
        for cell in cells:
            session.add(
                Job(
                    kind="train",
                    spec=_cell_spec(cell),
                    resolved={
                        "config": dict(cell.config),
                        "cell": {
                            "experiment": cell.experiment,
                            "key": cell.key,
                            "label": cell.label,
                            "algo": cell.algo,
                            "reward": cell.reward,
                            "seed": cell.seed,
                        },
                    },
                    status="queued",
                    progress_total=None,
                    run_dir=Path(cell.run_dir).relative_to(store.root).as_posix(),
                    experiment_id=experiment.id,
                    cell=cell.key,
                )
            )
        return experiment.id


def _cell_spec(cell: Any) -> dict[str, Any]:
    """The cell as a train spec, for reading (the job runs `resolved.config`, the cell's own config)."""
    from service.schemas.specs import _algo_names

    run = cell.config["run"]
    spec: dict[str, Any] = {"reward": cell.reward, "seed": cell.seed, "steps": int(run["steps"])}
    names = _algo_names()
    if names is None or cell.algo in names:  # a registered cell runner's method (an SB3 peer) is not
        spec["algo"] = cell.algo
    ac = cell.config.get("agent", {}).get("ac")
    if ac in ("ddpg", "cacla", "td3", "sac"):
        spec["ac"] = ac
    return spec


def get_experiment(database: Database, *, experiment_id: int) -> ExperimentState:
    with database.read() as session:
        experiment = session.get(Experiment, experiment_id)
        if experiment is None:
            raise ExperimentNotFound(f"no experiment with id {experiment_id}")
        columns = (Job.id, Job.cell, Job.status, Job.attempt, Job.progress_episode, Job.reason, Job.run_dir)
        jobs = list(
            session.execute(select(*columns).where(Job.experiment_id == experiment_id).order_by(Job.id))
        )
    counts: dict[str, int] = {}
    for job in jobs:
        counts[job.status] = counts.get(job.status, 0) + 1
    return ExperimentState(experiment=experiment, jobs=jobs, counts=counts)


def list_experiments(database: Database, *, offset: int, limit: int) -> tuple[list[Experiment], int]:
    with database.read() as session:
        rows = list(
            session.scalars(select(Experiment).order_by(Experiment.id.desc()).offset(offset).limit(limit))
        )
        return rows, int(session.scalar(select(func.count()).select_from(Experiment)) or 0)


def cancel_experiment(database: Database, *, experiment_id: int) -> list[int]:
    """Cancel every unfinished cell (queued at once, running ones by their supervisor); their ids."""
    with database.write() as session:
        experiment = session.get(Experiment, experiment_id)
        if experiment is None:
            raise ExperimentNotFound(f"no experiment with id {experiment_id}")
        experiment.cancel_requested = True
        unfinished = session.scalars(
            select(Job.id).where(Job.experiment_id == experiment_id, Job.status.not_in(FINISHED_STATUSES))
        ).all()
    cancelled = []
    for job_id in unfinished:
        try:
            job_store.request_cancel(database, job_id=job_id)
            cancelled.append(job_id)
        except (JobNotFound, JobConflict):
            continue  # finished in the meantime
    return cancelled


def delete_experiment(database: Database, *, experiment_id: int) -> str:
    """Delete a finished experiment's rows (the experiment, its cells' jobs, metrics and artifact
    records) in one transaction; its folder (relative to the artifact root) for the caller to remove.
    409 while a cell is queued or running."""
    with database.write() as session:
        experiment = session.get(Experiment, experiment_id)
        if experiment is None:
            raise ExperimentNotFound(f"no experiment with id {experiment_id}")
        unfinished = session.scalar(
            select(func.count()).where(
                Job.experiment_id == experiment_id, Job.status.not_in(FINISHED_STATUSES)
            )
        )
        if unfinished:
            raise JobConflict(
                f"experiment {experiment_id} has {unfinished} unfinished cell(s); "
                "cancel it (POST /experiments/{id}/cancel) or wait before deleting"
            )
        cells = select(Job.id).where(Job.experiment_id == experiment_id).scalar_subquery()
        session.execute(delete(JobMetric).where(JobMetric.job_id.in_(cells)))
        session.execute(delete(JobArtifact).where(JobArtifact.job_id.in_(cells)))
        session.execute(delete(Job).where(Job.experiment_id == experiment_id))
        directory = f"{EXPERIMENTS_AREA}/{experiment.id}"
        session.delete(experiment)
        return directory
