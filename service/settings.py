"""Service settings (pydantic-settings, env prefix `DUALSYS_`): every knob of `dualsys serve`.

`DUALSYS_DATABASE_URL` and `DUALSYS_ARTIFACTS` are inherited from the registry's settings, so the
service and the registry always agree on where things live. `DUALSYS_TOKEN` is the bearer token for
mutating endpoints; without one the service binds only to loopback addresses.
"""

from __future__ import annotations

import ipaddress
from typing import Literal

from pydantic import Field, SecretStr

from registry.settings import RegistrySettings


class InsecureBindError(ValueError):
    """Binding a non-loopback address without `DUALSYS_TOKEN`."""


def is_loopback(host: str) -> bool:
    """True for `localhost` and addresses in 127.0.0.0/8 or ::1."""
    if host.strip().lower() in ("localhost", "localhost.localdomain"):
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


class ServiceSettings(RegistrySettings):
    """Everything `dualsys serve` reads; each field can come from `DUALSYS_<FIELD>`."""

    host: str = "127.0.0.1"
    """Address uvicorn binds to; non-loopback addresses need a token."""
    port: int = Field(default=8000, ge=0, le=65535)
    """TCP port (0: any free port)."""
    token: SecretStr | None = None
    """Bearer token required by every mutating endpoint (POST/PUT/DELETE)."""
    workers: int = Field(default=1, ge=1, le=64)
    """Jobs run at the same time (one process or Ray task each)."""
    executor: Literal["local", "ray"] = "local"
    """local: a process per job on this machine; ray: a Ray task per job."""
    ray_address: str | None = None
    """Ray cluster address for the ray executor (None: start a local Ray)."""
    ray_num_cpus: int | None = None
    """CPUs of a locally started Ray (None: Ray decides)."""
    heartbeat_interval_s: float = Field(default=1.0, gt=0)
    """How often a running job's worker writes its heartbeat."""
    heartbeat_timeout_s: float = Field(default=20.0, gt=0)
    """A running job whose heartbeat is older than this has lost its worker and is recovered."""
    poll_interval_s: float = Field(default=0.25, gt=0)
    """How often the supervisor looks for queued jobs, exits, cancels and stale heartbeats."""
    cancel_grace_s: float = Field(default=5.0, ge=0)
    """Seconds a cancelled/interrupted worker gets to stop before it is killed."""
    worker_nice: int = Field(default=10, ge=0, le=19)
    """CPU niceness added to job processes, so training never starves the API (0: same priority)."""
    max_attempts: int = Field(default=3, ge=1)
    """Attempts per job before a lost job is marked failed instead of re-queued."""
    recovery: Literal["requeue", "fail"] = "requeue"
    """What happens to a job whose worker died: re-queue (resuming from its checkpoint) or fail."""
    max_request_bytes: int = Field(default=1_000_000, ge=1024)
    """Largest request body accepted (413 beyond)."""
    request_threads: int = Field(default=4, ge=1, le=256)
    """Threads that run request handlers (database calls); more only adds GIL contention."""
    run_jobs: bool = True
    """Run the supervisor in this process (false: an API-only replica that only queues)."""
    access_log: bool = False
    """Log every request line (uvicorn's access log: about 0.1 ms of CPU per request; off by default)."""
    api_processes: int = Field(default=1, ge=1, le=32)
    """Processes serving the API on one port (>1: a parent process runs the one supervisor, and the
    API processes only queue; see service/server.py)."""

    def check_bind(self) -> None:
        """Refuse a non-loopback host without a token (raises InsecureBindError)."""
        if not is_loopback(self.host) and (self.token is None or not self.token.get_secret_value()):
            raise InsecureBindError(
                f"refusing to bind {self.host}: a non-loopback address needs a bearer token "
                "(set DUALSYS_TOKEN)"
            )
