from __future__ import annotations

from pathlib import Path

import pytest

from registry import PolicyRegistry


@pytest.fixture()
def policy_registry(database_url: str, tmp_path: Path) -> PolicyRegistry:
    """A registry on a SQLite file, and again on PostgreSQL (`database_url` in tests/conftest.py)."""
    registry = PolicyRegistry.open(database_url, tmp_path / "artifacts")
    yield registry
    registry.database.dispose()
