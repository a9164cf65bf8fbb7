from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from tests.utils.live_service import LiveService


@pytest.fixture()
def start_service(tmp_path: Path) -> Iterator[Callable[..., LiveService]]:
    """Start real services (uvicorn processes) on tmp_path; all are killed at teardown."""
    started: list[LiveService] = []

    def start(name: str = "svc", **settings) -> LiveService:
        service = LiveService(tmp_path / name, **settings)
        started.append(service)
        return service.start()

    yield start
    for service in started:
        service.kill()
