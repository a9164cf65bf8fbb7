"""A throwaway PostgreSQL server from Debian's packages, started in a temporary folder: for the service
benchmark (`dualsys bench service --database postgresql`) and, through tests/utils/postgres_server.py, for
the tests.

`initdb` + `pg_ctl` from `/usr/lib/postgresql/<version>/bin` (installed by scripts/system-packages.sh),
trust authentication, listening on a free loopback port. PostgreSQL refuses to run as root, so as root
(CI, the dev machines) the server runs as the `postgres` user that the Debian package creates, through
`runuser`; its folder is made by us and handed to that user. `create_database` gives each caller a fresh
database. `PostgresUnavailable` says why a server could not be had (no binaries, no unprivileged user).
"""

from __future__ import annotations

import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import uuid
from pathlib import Path

SERVER_USER = "postgres"
SUPERUSER = "dualsys"


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


class PostgresUnavailable(RuntimeError):
    """No PostgreSQL server can be started here; the message says why."""


def find_bin_dir() -> Path:
    """The newest `/usr/lib/postgresql/<version>/bin` holding initdb and pg_ctl."""
    candidates = sorted(
        Path("/usr/lib/postgresql").glob("*/bin"),
        key=lambda path: int(path.parent.name) if path.parent.name.isdigit() else 0,
        reverse=True,
    )
    for candidate in candidates:
        if (candidate / "initdb").is_file() and (candidate / "pg_ctl").is_file():
            return candidate
    raise PostgresUnavailable(
        "no PostgreSQL server binaries in /usr/lib/postgresql/*/bin "
        "(run `bash scripts/system-packages.sh` as root, or `apt-get install postgresql`)"
    )


class PostgresServer:
    """One PostgreSQL cluster in a temporary folder, on 127.0.0.1:<free port>."""

    def __init__(self, *, durable: bool = False) -> None:
        """`durable=False` (the tests): no fsync at all. `durable=True` (the benchmark): fsync and full page
        writes on, commits acknowledged before their WAL flush (`synchronous_commit=off`), which is what the
        service's SQLite does (WAL with `synchronous=NORMAL`): a crash may lose the last commits, never
        corrupt the database."""
        self.durable = durable
        self.bin_dir = find_bin_dir()
        self.as_user: str | None = None
        if os.geteuid() == 0:
            try:
                pwd.getpwnam(SERVER_USER)
            except KeyError as error:
                raise PostgresUnavailable(
                    f"running as root and there is no {SERVER_USER!r} user to run PostgreSQL as"
                ) from error
            if shutil.which("runuser") is None:
                raise PostgresUnavailable("running as root and `runuser` is missing")
            self.as_user = SERVER_USER
        self.folder = Path(tempfile.mkdtemp(prefix="dualsys-postgres-"))
        self.data = self.folder / "data"
        self.port = 0

    def _run(self, *command: str) -> subprocess.CompletedProcess[str]:
        prefix = ["runuser", "-u", self.as_user, "--"] if self.as_user else []
        return subprocess.run(
            [*prefix, *command], capture_output=True, text=True, timeout=120, cwd=self.folder, check=False
        )

    def start(self) -> PostgresServer:
        if self.as_user is not None:
            record = pwd.getpwnam(self.as_user)
            os.chown(self.folder, record.pw_uid, record.pw_gid)
        self.folder.chmod(0o700)
        initdb = self._run(
            str(self.bin_dir / "initdb"),
            "-D", str(self.data), "-U", SUPERUSER, "--auth=trust", "-E", "UTF8", "--no-sync",
        )  # fmt: skip
        if initdb.returncode != 0:
            raise PostgresUnavailable(f"initdb failed: {initdb.stderr.strip() or initdb.stdout.strip()}")
        self.port = free_port()
        safety = "" if self.durable else "-c fsync=off -c full_page_writes=off "
        options = (
            f"-c listen_addresses=127.0.0.1 -p {self.port} -k {self.folder} "
            f"{safety}-c synchronous_commit=off -c max_connections=200"
        )
        started = self._run(
            str(self.bin_dir / "pg_ctl"), "-D", str(self.data), "-o", options,
            "-l", str(self.folder / "server.log"), "-w", "-t", "60", "start",
        )  # fmt: skip
        if started.returncode != 0:
            log = (self.folder / "server.log").read_text(errors="replace") if self.folder.exists() else ""
            raise PostgresUnavailable(f"pg_ctl start failed: {started.stderr.strip()} {log[-2000:]}")
        return self

    def url(self, database: str = "postgres") -> str:
        return f"postgresql+psycopg://{SUPERUSER}@127.0.0.1:{self.port}/{database}"

    def create_database(self) -> str:
        """A fresh, empty database; returns its SQLAlchemy URL."""
        import psycopg

        name = f"t_{uuid.uuid4().hex[:12]}"
        with psycopg.connect(f"host=127.0.0.1 port={self.port} user={SUPERUSER} dbname=postgres") as admin:
            admin.autocommit = True
            admin.execute(f'CREATE DATABASE "{name}"')
        return self.url(name)

    def stop(self) -> None:
        if self.port:
            self._run(str(self.bin_dir / "pg_ctl"), "-D", str(self.data), "-m", "immediate", "-w", "stop")
        shutil.rmtree(self.folder, ignore_errors=True)
