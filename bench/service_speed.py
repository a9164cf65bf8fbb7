"""Latency of the job service under load: p50/p99 of `GET /jobs` (first page, 10 000 jobs in the table)
and `POST /jobs` from 20 concurrent clients while a training job runs, for 1, 2, ... API processes
(`dualsys serve --api-processes N`), on SQLite and on PostgreSQL. Goals: p99 < 50 ms with 2 API
processes, at least 2x the 213 requests/s measured with one, at most 2 ms of server CPU per request.
Prints JSON; never asserts.

The service runs as real uvicorn processes on a loopback port with one worker slot, which the training
job holds: the submitted `probe` jobs stay queued, so the measurement sees the API and the database
while the trainer competes for the CPU. The database is a SQLite file in a temporary folder, or a fresh
database on a throwaway PostgreSQL server (`bench/postgres_server.py`, durability as SQLite's WAL with
synchronous=NORMAL: fsync on, commits acknowledged before their WAL flush). Server CPU is that of the
service's processes (the parent with the supervisor and every API process), not of the job processes
(nor of PostgreSQL's, which `postgres_cpu_ms_per_request` reports).

`repeat` runs each configuration several times, interleaved (sqlite-1, sqlite-2, postgresql-1, ...,
then again), and `summary` gives the median of each figure over the repeats: the machine is shared, so
one run says little. `profile_dir` records each service process with py-spy during the load (raw
collapsed stacks, one file per process), for `bench/profile_summary.py`.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

PROJECT_ROOT = Path(__file__).resolve().parents[1]
TOKEN = "bench-token"


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    if not ordered:
        return float("nan")
    index = min(len(ordered) - 1, max(0, round(q / 100 * (len(ordered) - 1))))
    return ordered[index]


def _process_cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (Linux /proc; NaN elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


def _service_pids(root: int) -> list[int]:
    """The service's processes: `root` and its descendants, except job processes
    (`service.execution.worker`)."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    found, frontier = [root], [root]
    while frontier:
        children = [pid for pid, parent in parents.items() if parent in frontier]
        found += children
        frontier = children
    service = []
    for pid in found:
        try:
            if b"service.execution.worker" not in Path(f"/proc/{pid}/cmdline").read_bytes():
                service.append(pid)
        except OSError:
            continue
    return service


def _service_cpu_s(pids: list[int]) -> float:
    """CPU seconds of the processes still alive (a PostgreSQL backend that ended takes its share along)."""
    return sum(cpu for cpu in (_process_cpu_s(pid) for pid in pids) if math.isfinite(cpu))


def _postgres_pids(port: int) -> list[int]:
    """PostgreSQL's server processes (the postmaster listening on `port` and its children)."""
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            command = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if command and command[0].endswith(b"postgres") and str(port).encode() in command:
            return _service_pids(int(entry.name))
    return []


def _profile(pids: list[int], seconds: float, folder: Path, label: str) -> list[subprocess.Popen[bytes]]:
    """py-spy record of each process for `seconds` (raw collapsed stacks), non-blocking (it samples without
    stopping the process), only samples whose thread holds the GIL (the CPU a process spends in Python,
    not its idle threads); one file per process under `folder`."""
    spy = shutil.which("py-spy", path=str(Path(sys.executable).parent)) or shutil.which("py-spy")
    if spy is None:
        raise RuntimeError("py-spy is not installed (pip install 'dualsys[bench]')")
    folder.mkdir(parents=True, exist_ok=True)
    return [
        subprocess.Popen(
            [
                spy, "record", "--pid", str(pid), "--duration", str(max(1, round(seconds))),
                "--rate", "250", "--nonblocking", "--gil", "--format", "raw",
                "--output", str(folder / f"{label}-pid{pid}.txt"),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        for pid in pids
    ]  # fmt: skip


def _summary(latencies: list[float], errors: int) -> dict[str, Any]:
    milliseconds = [1000 * v for v in latencies]
    return {
        "requests": len(milliseconds),
        "errors": errors,
        "p50_ms": round(_percentile(milliseconds, 50), 2),
        "p99_ms": round(_percentile(milliseconds, 99), 2),
        "mean_ms": round(statistics.fmean(milliseconds), 2) if milliseconds else None,
        "max_ms": round(max(milliseconds), 2) if milliseconds else None,
    }


class _Connection:
    """A minimal HTTP/1.1 keep-alive client on asyncio streams.

    The load generator shares the 2-core machine with the service: httpx costs ~3 ms of CPU per
    request, as much as the service itself, so the bench speaks HTTP directly (~0.1 ms) to measure
    the service rather than its client.
    """

    def __init__(self, host: str, port: int) -> None:
        self.host, self.port = host, port
        self.reader: asyncio.StreamReader | None = None
        self.writer: asyncio.StreamWriter | None = None

    async def request(self, method: str, target: str, body: bytes = b"") -> int:
        if self.writer is None:
            self.reader, self.writer = await asyncio.open_connection(self.host, self.port)
        head = (
            f"{method} {target} HTTP/1.1\r\nHost: {self.host}:{self.port}\r\n"
            f"Authorization: Bearer {TOKEN}\r\nContent-Length: {len(body)}\r\n"
            + ("Content-Type: application/json\r\n" if body else "")
            + "\r\n"
        )
        self.writer.write(head.encode() + body)
        await self.writer.drain()
        assert self.reader is not None
        headers = await self.reader.readuntil(b"\r\n\r\n")
        status = int(headers.split(b" ", 2)[1])
        length = 0
        for line in headers.split(b"\r\n"):
            if line[:15].lower() == b"content-length:":
                length = int(line[15:])
        await self.reader.readexactly(length)
        return status

    async def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
            with contextlib.suppress(Exception):
                await self.writer.wait_closed()


async def _load(url: str, clients: int, seconds: float) -> dict[str, Any]:
    host, port = url.removeprefix("http://").split(":")
    latencies: dict[str, list[float]] = {"GET /jobs": [], "POST /jobs": []}
    errors = {"GET /jobs": 0, "POST /jobs": 0}
    deadline = time.perf_counter() + seconds
    body = json.dumps({"kind": "probe", "spec": {"episodes": 1, "interval_s": 0}}).encode()

    async def one_client(index: int) -> None:
        connection = _Connection(host, int(port))
        turn = index
        try:
            while time.perf_counter() < deadline:
                name = "GET /jobs" if turn % 2 == 0 else "POST /jobs"
                turn += 1
                started = time.perf_counter()
                if name == "GET /jobs":
                    ok = await connection.request("GET", "/jobs?limit=20") == 200
                else:
                    ok = await connection.request("POST", "/jobs", body) == 202
                latencies[name].append(time.perf_counter() - started)
                errors[name] += not ok
        finally:
            await connection.close()

    await asyncio.gather(*(one_client(i) for i in range(clients)))
    return {name: _summary(latencies[name], errors[name]) for name in latencies}


def _fill_table(database_url: str, template_id: int, count: int) -> None:
    """`count` finished copies of job `template_id` (a train job with its resolved config)."""
    from sqlalchemy import insert, select

    from registry.database import Database
    from service.database.models import Job

    database = Database(database_url)
    try:
        with database.write() as session:
            template = session.get(Job, template_id)
            assert template is not None
            row = {
                "kind": template.kind,
                "spec": template.spec,
                "resolved": template.resolved,
                "status": "succeeded",
                "progress_total": template.progress_total,
                "progress_episode": template.progress_total or 0,
                "attempt": 1,
                "created_at": template.created_at,
                "started_at": template.created_at,
                "finished_at": template.created_at,
                "summary": {"episodes": template.progress_total},
            }
            session.execute(insert(Job), [row] * count)
            session.execute(
                Job.__table__.update()
                .where(Job.run_dir == "")
                .values(run_dir="jobs/" + Job.id.cast(type_=Job.run_dir.type))
            )
            assert session.scalar(select(Job.id).where(Job.id == template_id)) == template_id
    finally:
        database.dispose()


def measure_one(
    *,
    seconds: float,
    clients: int,
    api_processes: int,
    jobs_in_table: int,
    database_url: str | None = None,
    postgres_port: int | None = None,
    profile_dir: Path | None = None,
    label: str = "",
) -> dict[str, Any]:
    """Start a service with `api_processes`, a training job and `jobs_in_table` jobs; load it; stop it.
    `database_url`: a fresh PostgreSQL database (on the server at `postgres_port`); None: a SQLite file."""
    folder = Path(tempfile.mkdtemp(prefix="dualsys-bench-service-"))
    port = _free_port()
    database_url = database_url or f"sqlite:///{folder / 'bench.db'}"
    environment = {k: v for k, v in os.environ.items() if not k.startswith("DUALSYS_")}
    environment.update(
        DUALSYS_DATABASE_URL=database_url,
        DUALSYS_ARTIFACTS=str(folder / "artifacts"),
        DUALSYS_PORT=str(port),
        DUALSYS_TOKEN=TOKEN,
        DUALSYS_WORKERS="1",
        DUALSYS_API_PROCESSES=str(api_processes),
        PYTHONPATH=os.pathsep.join([str(PROJECT_ROOT), os.environ.get("PYTHONPATH", "")]),
    )
    log = open(folder / "server.log", "wb")  # noqa: SIM115 - closed below
    server = subprocess.Popen(
        [sys.executable, "-m", "service.server"], env=environment, stdout=log, stderr=log
    )
    url = f"http://127.0.0.1:{port}"
    try:
        with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=300) as client:
            deadline = time.monotonic() + 300  # a loaded machine takes minutes to import torch
            while True:
                try:
                    if client.get("/health").status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                if time.monotonic() > deadline or server.poll() is not None:
                    raise RuntimeError(f"the service did not start; see {folder / 'server.log'}")
                time.sleep(0.2)
            train = {"algo": "ddpg", "episodes": 1_000_000, "overrides": {"run.eval_every": 0}}
            job = client.post("/jobs", json={"kind": "train", "spec": train}).json()
            _fill_table(database_url, job["id"], jobs_in_table - 1)
            while client.get(f"/jobs/{job['id']}").json()["progress"]["episode"] < 1:
                if time.monotonic() > deadline + 120:
                    raise RuntimeError("the training job did not start")
                time.sleep(0.2)
            for _ in range(3 * api_processes):  # every API process has answered once (lazy imports)
                client.get("/jobs?limit=20")
            before = client.get(f"/jobs/{job['id']}").json()["progress"]["episode"]
            pids = _service_pids(server.pid)
            database_pids = _postgres_pids(postgres_port) if postgres_port else []
            server_cpu = _service_cpu_s(pids)
            database_cpu = _service_cpu_s(database_pids)
            client_cpu = time.process_time()
            spies = _profile(pids, seconds, profile_dir, label) if profile_dir else []
            load_before = os.getloadavg()[0]
            results = asyncio.run(_load(url, clients, seconds))
            client_cpu = time.process_time() - client_cpu
            server_cpu = _service_cpu_s(pids) - server_cpu
            database_cpu = _service_cpu_s(database_pids) - database_cpu
            for spy in spies:
                spy.wait(timeout=60)
            after = client.get(f"/jobs/{job['id']}").json()
            count = client.get("/jobs?limit=1").json()["count"]
            client.post(f"/jobs/{job['id']}/cancel")
        requests = sum(figures["requests"] for figures in results.values())
        return {
            "database": database_url.split(":", 1)[0].split("+", 1)[0],
            "api_processes": api_processes,
            "service_processes": len(pids),
            "jobs_in_table_after": count,
            "training_job_status": after["status"],
            "training_episodes_during_load": after["progress"]["episode"] - before,
            **{f"{name} {key}": value for name, figures in results.items() for key, value in figures.items()},
            "requests_per_s": round(requests / seconds, 1),
            "server_cpu_ms_per_request": round(1000 * server_cpu / max(requests, 1), 2),
            "client_cpu_ms_per_request": round(1000 * client_cpu / max(requests, 1), 2),
            **(
                {"postgres_cpu_ms_per_request": round(1000 * database_cpu / max(requests, 1), 2)}
                if postgres_port
                else {}
            ),
            "load_average_1m_before": round(load_before, 2),
            "load_average_1m_after": round(os.getloadavg()[0], 2),
        }
    finally:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
        log.close()
        shutil.rmtree(folder, ignore_errors=True)


SUMMARY_KEYS = (
    "GET /jobs p50_ms",
    "GET /jobs p99_ms",
    "POST /jobs p50_ms",
    "POST /jobs p99_ms",
    "requests_per_s",
    "server_cpu_ms_per_request",
    "postgres_cpu_ms_per_request",
    "load_average_1m_before",
)


def summarise(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (database, API processes): the median of each figure over the repeats, and their range."""
    groups: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for run in runs:
        groups.setdefault((run["database"], run["api_processes"]), []).append(run)
    summary = []
    for (database, processes), group in groups.items():
        row: dict[str, Any] = {"database": database, "api_processes": processes, "repeats": len(group)}
        for key in SUMMARY_KEYS:
            values = [run[key] for run in group if isinstance(run.get(key), int | float)]
            if values:
                row[f"{key} median"] = round(statistics.median(values), 2)
                row[f"{key} range"] = [round(min(values), 2), round(max(values), 2)]
        summary.append(row)
    return summary


def measure(
    seconds: float = 10.0,
    clients: int = 20,
    api_processes: tuple[int, ...] = (1,),
    jobs_in_table: int = 10_000,
    databases: tuple[str, ...] = ("sqlite",),
    repeat: int = 1,
    profile_dir: Path | None = None,
) -> dict[str, Any]:
    """Every (database, API-process count) `repeat` times, interleaved, with the goals and the medians."""
    load_before = round(os.getloadavg()[0], 2)
    postgres = None
    if "postgresql" in databases:
        from bench.postgres_server import PostgresServer

        postgres = PostgresServer(durable=True).start()
    runs = []
    try:
        for round_index in range(repeat):
            for database in databases:
                for n in api_processes:
                    url = postgres.create_database() if database == "postgresql" and postgres else None
                    runs.append(
                        measure_one(
                            seconds=seconds,
                            clients=clients,
                            api_processes=n,
                            jobs_in_table=jobs_in_table,
                            database_url=url,
                            postgres_port=postgres.port if url and postgres else None,
                            profile_dir=profile_dir,
                            label=f"{database}-{n}api-r{round_index + 1}",
                        )
                    )
    finally:
        if postgres is not None:
            postgres.stop()
    return {
        "clients": clients,
        "seconds": seconds,
        "jobs_in_table": jobs_in_table,
        "goal_p99_ms": 50,
        "goal_requests_per_s": 2 * 213,
        "goal_server_cpu_ms_per_request": 2.0,
        "cpu_count": os.cpu_count(),
        "load_average_1m_before": load_before,
        "summary": summarise(runs),
        "runs": runs,
    }


if __name__ == "__main__":  # pragma: no cover
    print(json.dumps(measure()))
