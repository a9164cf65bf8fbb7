"""Test factories shared by tests/registry and tests/service (mirrors FastAPI's template layout)."""
