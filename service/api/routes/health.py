"""`GET /health`: the database answers, which executor runs jobs, and the queue's counts.

`pid` names the API process that answered (with `dualsys serve --api-processes N` there are N)."""

from __future__ import annotations

import os
from typing import Any

from fastapi import APIRouter
from sqlalchemy import text

from service.database import job_store
from service.deps import StateDep

router = APIRouter(tags=["health"])


@router.get("/health")
def health(state: StateDep) -> dict[str, Any]:
    with state.database.read() as session:
        session.execute(text("SELECT 1"))
    return {
        "status": "ok",
        "database": state.database.engine.dialect.name,
        "executor": state.settings.executor,
        "workers": state.settings.workers,
        "running_jobs": state.supervisor is not None,
        "pid": os.getpid(),
        "jobs": job_store.count_by_status(state.database),
    }
