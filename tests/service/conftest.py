from __future__ import annotations

import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.utils.browser import browser_or_skip
from tests.utils.live_service import LiveService


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """One headless Chromium per test module (skips with the reason when none is installed here)."""
    driver, profile = browser_or_skip()
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


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
