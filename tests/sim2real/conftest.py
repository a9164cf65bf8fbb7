from __future__ import annotations

from pathlib import Path

import pytest

from tests.utils.tiny_policy import train_tiny_policy


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real trained run directory (hand="auto": 1-d actions)."""
    return train_tiny_policy(tmp_path_factory.mktemp("sim2real") / "run")

