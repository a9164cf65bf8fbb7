"""Executors run claimed jobs: `local` (a process per job) and `ray` (a Ray task per job)."""

from __future__ import annotations

from service.execution.executors.base import Executor, WorkerExit

__all__ = ["Executor", "WorkerExit", "make_executor"]


def make_executor(settings, owner: str, database) -> Executor:  # type: ignore[no-untyped-def]
    """The executor `settings.executor` names (Ray is imported only when asked for).

    It shares the service's `Database`, whose in-process write lock then orders every write.
    """
    if settings.executor == "ray":
        from service.execution.executors.ray_executor import RayExecutor

        return RayExecutor(settings, owner, database)
    from service.execution.executors.local import LocalExecutor

    return LocalExecutor(settings, owner, database)
