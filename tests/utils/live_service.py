"""Factory: the real job service under uvicorn, as its own process on a free loopback port.

Tests talk to it over HTTP with httpx, against a real SQLite file under the test's tmp_path, and
can stop it gracefully (SIGTERM), kill it (SIGKILL) and start a new one on the same database.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import httpx

PROJECT_ROOT = Path(__file__).resolve().parents[2]
T = TypeVar("T")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def wait_for(
    predicate: Callable[[], T], *, timeout: float = 30.0, interval: float = 0.1, what: str = ""
) -> T:
    """Poll `predicate` until it returns a truthy value; fail the test after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what or predicate}")
        time.sleep(interval)


class LiveService:
    """One `python -m service.server` process configured through DUALSYS_* variables."""

    def __init__(self, folder: Path, *, token: str | None = "test-token", **settings: Any) -> None:
        self.folder = folder
        self.folder.mkdir(parents=True, exist_ok=True)
        self.token = token
        self.settings = {
            "database_url": f"sqlite:///{folder / 'dualsys.db'}",
            "artifacts": str(folder / "artifacts"),
            "heartbeat_interval_s": "0.5",
            "poll_interval_s": "0.1",
            "cancel_grace_s": "3",
            # normal priority for job processes: on a busy shared test machine niced jobs crawl
            "worker_nice": "0",
            **{k: str(v) for k, v in settings.items()},
        }
        self.process: subprocess.Popen[bytes] | None = None
        self.port = 0
        self.starts = 0

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def artifacts(self) -> Path:
        return Path(self.settings["artifacts"])

    def start(self, timeout: float = 180.0) -> LiveService:
        self.port = free_port()
        self.starts += 1
        environment = {k: v for k, v in os.environ.items() if not k.startswith("DUALSYS_")}
        environment.update({f"DUALSYS_{k.upper()}": v for k, v in self.settings.items()})
        environment["DUALSYS_PORT"] = str(self.port)
        environment["DUALSYS_HOST"] = "127.0.0.1"
        if self.token:
            environment["DUALSYS_TOKEN"] = self.token
        environment["PYTHONPATH"] = os.pathsep.join([str(PROJECT_ROOT), environment.get("PYTHONPATH", "")])
        log = open(self.folder / f"server-{self.starts}.log", "wb")  # noqa: SIM115 - owned by the process
        self.process = subprocess.Popen(
            [sys.executable, "-m", "service.server"], stdout=log, stderr=subprocess.STDOUT, env=environment
        )

        def healthy() -> bool:
            assert self.process is not None
            if self.process.poll() is not None:
                raise AssertionError(f"service exited early:\n{self.log()}")
            try:
                return httpx.get(f"{self.url}/health", timeout=1.0).status_code == 200
            except httpx.HTTPError:
                return False

        wait_for(healthy, timeout=timeout, interval=0.2, what="the service to answer /health")
        return self

    def log(self) -> str:
        return (self.folder / f"server-{self.starts}.log").read_text(errors="replace")

    def client(self, *, auth: bool = True, timeout: float = 30.0) -> httpx.Client:
        headers = {"Authorization": f"Bearer {self.token}"} if auth and self.token else {}
        return httpx.Client(base_url=self.url, headers=headers, timeout=timeout)

    def stop(self, timeout: float = 30.0) -> int | None:
        """Graceful stop (SIGTERM): the service interrupts its workers and re-queues their jobs."""
        if self.process is None or self.process.poll() is not None:
            return None if self.process is None else self.process.returncode
        self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            return self.process.wait()

    def kill(self) -> None:
        """Crash the service (SIGKILL): no shutdown code runs."""
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait()
