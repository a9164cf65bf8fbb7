"""Factory: episode records written straight into a real service database (SQLite file or PostgreSQL), as
the job recorder stores them, for tests that need long histories in seconds (a 20 000-episode run, an
experiment's cells) without training anything."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from sqlalchemy import insert, update

from registry.database import Database
from service.database.models import Job, JobMetric


def probe_like_record(episode: int, *, evaluated: bool = False, offset: float = 0.0) -> dict[str, Any]:
    """A training episode's record (the keys the dashboard draws); a greedy evaluation when `evaluated`."""
    return {
        "episode": episode,
        "global_step": 7 * episode,
        "charts/episodic_return": math.sin(episode / 50) + offset,
        "charts/success": float(episode % 3 == 0),
        "eval/success_rate": 0.5 if evaluated else None,  # the trainer's NaN is stored as null
        "eval/return": -1.0 if evaluated else None,
    }


def record_episodes(
    database_url: str,
    job_id: int,
    episodes: int,
    make: Callable[[int], dict[str, Any]] = probe_like_record,
) -> None:
    """Episodes 1..`episodes` of job `job_id`, and its progress, in one transaction."""
    database = Database(database_url)
    try:
        rows = [
            {"job_id": job_id, "episode": e, "global_step": 7 * e, "attempt": 1, "data": make(e)}
            for e in range(1, episodes + 1)
        ]
        with database.write() as session:
            session.execute(insert(JobMetric), rows)
            session.execute(update(Job).where(Job.id == job_id).values(progress_episode=episodes))
    finally:
        database.dispose()
