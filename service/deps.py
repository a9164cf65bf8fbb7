"""The dependencies the API's routes (`service.api`) and the dashboard's pages (`service.ui`) share: the
service state (`ServiceState`, `StateDep`) and the bearer-token check (`MutationAuth`).

Below both, so neither imports the other: the API process's app is composed above them, in
`service.server.create_app`.
"""

from __future__ import annotations

import secrets
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Annotated, Any, TypeVar

from fastapi import Depends, HTTPException, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.concurrency import run_in_threadpool

from registry import PolicyRegistry
from registry.database import Database
from service.database.job_inserter import JobInserter
from service.execution.supervisor import Supervisor
from service.settings import ServiceSettings

T = TypeVar("T")


@dataclass
class ServiceState:
    settings: ServiceSettings
    database: Database
    registry: PolicyRegistry
    supervisor: Supervisor | None
    inserter: JobInserter

    async def query(self, function: Callable[..., T], /, *args: Any, **kwargs: Any) -> T:
        """Run a short store call where it costs least: on the event loop for SQLite (embedded: the call
        is CPU work that never waits, so a thread would only add GIL hand-offs), in the thread pool for a
        database server (PostgreSQL: network round trips, which threads overlap)."""
        if self.database.engine.dialect.name == "sqlite":
            return function(*args, **kwargs)
        return await run_in_threadpool(partial(function, *args, **kwargs))


async def get_state(request: Request) -> ServiceState:
    """Async on purpose: FastAPI runs sync dependencies in the thread pool (one more hop per request)."""
    return request.app.state.service


StateDep = Annotated[ServiceState, Depends(get_state)]
_bearer = HTTPBearer(auto_error=False, description="DUALSYS_TOKEN, required by every mutating endpoint.")


async def require_token(
    state: StateDep, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]
) -> None:
    """401 unless the request carries `Authorization: Bearer <DUALSYS_TOKEN>` (when a token is set)."""
    expected = state.settings.token.get_secret_value() if state.settings.token else ""
    if not expected:
        return
    given = credentials.credentials if credentials is not None else ""
    if not secrets.compare_digest(given.encode(), expected.encode()):
        raise HTTPException(
            status_code=status.HTTP_401_UNAUTHORIZED,
            detail="missing or invalid bearer token (send Authorization: Bearer $DUALSYS_TOKEN)",
            headers={"WWW-Authenticate": "Bearer"},
        )


MutationAuth = Depends(require_token)
