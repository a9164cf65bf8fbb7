"""Schemathesis fuzzes every operation of the OpenAPI schema: no input makes the service answer 5xx."""

from __future__ import annotations

import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.utils.live_service import LiveService

pytest.importorskip("schemathesis", reason="schemathesis is in the dev extra")


def test_schemathesis_finds_no_server_error(start_service: Callable[..., LiveService]) -> None:
    # API only (no supervisor): generated jobs stay queued instead of running on the test machine
    service = start_service(run_jobs="false")
    executable = shutil.which("schemathesis", path=str(Path(sys.executable).parent)) or "schemathesis"
    command = [
        executable,
        "run",
        f"{service.url}/openapi.json",
        "--checks",
        "not_a_server_error",
        "--max-examples",
        "10",
        "--seed",
        "7",
        "--header",
        f"Authorization: Bearer {service.token}",
        "--exclude-path-regex",
        "events$",  # a live stream of a queued job never ends by design
        "--request-timeout",
        "10",
    ]
    # run in the test's folder: schemathesis keeps a `.schemathesis/` example database in its cwd
    result = subprocess.run(command, capture_output=True, text=True, timeout=240, cwd=service.folder)
    tail = result.stdout[-3000:] + result.stderr[-2000:]
    assert result.returncode == 0, tail
    assert " passed" in result.stdout and "failed" not in result.stdout.split("SUMMARY")[-1], tail
    assert "Traceback" not in service.log() and " 500 " not in service.log()
