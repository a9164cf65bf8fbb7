from __future__ import annotations

from pathlib import Path

import pytest

from registry import PolicyRegistry


@pytest.fixture()
def policy_registry(tmp_path: Path) -> PolicyRegistry:
    registry = PolicyRegistry.open(f"sqlite:///{tmp_path / 'registry.db'}", tmp_path / "artifacts")
    yield registry
    registry.database.dispose()
