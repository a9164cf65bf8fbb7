"""Weight and speed of the web dashboard: the jobs page of a service holding 1 000 jobs (goal: rendered
server-side in < 100 ms, p50 of 20 loads; the whole first load < 500 kB), and the page of a 100 000-episode
run (goal: first load ≤ 1 MB: the page draws a thinned series, every episode only on demand). Prints JSON
figures; never asserts.

The database is a real SQLite file filled through the job store: 1 000 jobs, mostly `train` jobs
carrying a real resolved config (what `POST /jobs` stores), across every status; five are running
with 1 000 recorded episodes each (greedy evaluations every 200), so the table's "current success"
column reads metric rows. The service is a real uvicorn process started as an API-only replica
(`DUALSYS_RUN_JOBS=false`: nothing runs or recovers the "running" jobs while we measure).

Figures: `render_ms` is the page handler's own time (queries + template), from the `Server-Timing`
header each page sends; `http_ms` is the request's wall time seen by the client (loopback). The
first load is the page, every script and style it links, and the first refresh its script makes.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import timedelta
from pathlib import Path
from typing import Any

import httpx
from sqlalchemy import insert, update

PROJECT_ROOT = Path(__file__).resolve().parents[1]
JOBS = 1000
RUNNING = 5
EPISODES = 1000
LONG_EPISODES = 100_000
"""Episodes of the long run whose page is weighed (a greedy evaluation every 1 000)."""
LOADS = 20
ASSET = re.compile(r'(?:src|href)="(/ui/static/[^"]+)"')


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    index = min(len(ordered) - 1, max(0, round(q / 100 * (len(ordered) - 1))))
    return ordered[index]


def _wire_bytes(response: httpx.Response) -> int:
    """Status line + headers + body as sent (the body as transferred, before any decoding)."""
    head = len(f"HTTP/1.1 {response.status_code} {response.reason_phrase}\r\n") + 2
    head += sum(len(k) + len(v) + 4 for k, v in response.headers.raw)
    return head + int(response.headers.get("content-length", len(response.content)))


def _server_ms(response: httpx.Response) -> float:
    match = re.search(r"render;dur=([\d.]+)", response.headers.get("server-timing", ""))
    return float(match.group(1)) if match else math.nan


def fill_database(url: str) -> int:
    """1 000 jobs through the job store, with statuses, progress, summaries and metric rows; the id of
    a running job."""
    from core.config import load_config
    from registry.database import Database
    from service.database import job_store
    from service.database.migrate import upgrade_service
    from service.database.models import Job, JobMetric

    database = Database(url)
    upgrade_service(database.engine)
    configs = [
        load_config("default", [f"run.algo={a}", f"run.seed={s}"]).to_dict()
        for a in ("i2a", "im2c", "ddpg", "cacla")
        for s in range(3)
    ]
    running: list[int] = []
    for index in range(JOBS):
        kind = "train" if index % 10 else "probe"
        config = configs[index % len(configs)]
        spec = (
            {"algo": config["run"]["algo"], "seed": config["run"]["seed"], "episodes": 5000}
            if kind == "train"
            else {"episodes": 100, "interval_s": 1.0}
        )
        job, _ = job_store.create_job(
            database,
            kind=kind,
            spec=spec,
            resolved={"config": config} if kind == "train" else {},
            progress_total=spec["episodes"],
        )
        status = ("succeeded", "succeeded", "failed", "cancelled", "queued")[index % 5]
        if index >= JOBS - RUNNING:
            status = "running"
            running.append(job.id)
        values: dict[str, Any] = {"status": status}
        if status != "queued":
            values.update(
                started_at=job.created_at, progress_episode=EPISODES if status == "running" else 5000
            )
        if status == "succeeded":
            values.update(
                finished_at=job.created_at + timedelta(minutes=30),
                summary={"success_rate": 0.8, "episodes": 5000, "steps": 120_000},
            )
        with database.write() as session:
            session.execute(update(Job).where(Job.id == job.id).values(**values))
    with database.write() as session:
        for job_id in running:
            rows = []
            for episode in range(1, EPISODES + 1):
                data = {
                    "charts/episodic_return": math.sin(episode / 50),
                    "charts/success": float(episode % 3 == 0),
                    "charts/length": 24,
                    "losses/critic": 0.1,
                    "dual/model_error": 0.05,
                    "dual/mb_decisions": 3.0,
                    "dual/mf_decisions": 21.0,
                    "dual/horizon": 2.5,
                    "dual/itm_nodes": 40.0,
                }
                if episode % 200 == 0:
                    data["eval/success_rate"] = episode / EPISODES
                rows.append(
                    {
                        "job_id": job_id,
                        "episode": episode,
                        "global_step": 24 * episode,
                        "attempt": 1,
                        "data": data,
                    }
                )
            session.execute(insert(JobMetric), rows)
    database.dispose()
    return running[0]


def _episode_record(episode: int, evaluate_every: int) -> dict[str, Any]:
    data: dict[str, Any] = {
        "charts/episodic_return": math.sin(episode / 50),
        "charts/success": float(episode % 3 == 0),
        "charts/length": 24,
        "losses/critic": 0.1,
        "dual/model_error": 0.05,
        "dual/mb_decisions": 3.0,
        "dual/mf_decisions": 21.0,
        "dual/horizon": 2.5,
        "dual/itm_nodes": 40.0,
    }
    if episode % evaluate_every == 0:
        data["eval/success_rate"] = 0.5
    return data


def add_long_run(url: str, episodes: int = LONG_EPISODES) -> int:
    """A finished train job with `episodes` recorded episodes; its id."""
    from registry.database import Database
    from service.database import job_store
    from service.database.models import Job, JobMetric

    database = Database(url)
    try:
        job, _ = job_store.create_job(
            database, kind="probe", spec={"episodes": episodes}, resolved={}, progress_total=episodes
        )
        with database.write() as session:
            session.execute(
                update(Job).where(Job.id == job.id).values(status="succeeded", progress_episode=episodes)
            )
        for start in range(1, episodes + 1, 20_000):
            rows = [
                {
                    "job_id": job.id,
                    "episode": e,
                    "global_step": 24 * e,
                    "attempt": 1,
                    "data": _episode_record(e, 1000),
                }
                for e in range(start, min(episodes, start + 19_999) + 1)
            ]
            with database.write() as session:
                session.execute(insert(JobMetric), rows)
        return job.id
    finally:
        database.dispose()


def _first_load(client: httpx.Client, path: str, follow_ups: list[str]) -> dict[str, Any]:
    page = client.get(path)
    parts = {path: _wire_bytes(page)}
    for asset in sorted(set(ASSET.findall(page.text))):
        parts[asset.split("?")[0]] = _wire_bytes(client.get(asset))
    for extra in follow_ups:
        parts[extra] = _wire_bytes(client.get(extra))
    return {"bytes": sum(parts.values()), "parts": parts}


def _timed(client: httpx.Client, path: str, loads: int) -> dict[str, float]:
    render, wall = [], []
    for _ in range(loads):
        started = time.perf_counter()
        response = client.get(path)
        wall.append(1000 * (time.perf_counter() - started))
        response.raise_for_status()
        render.append(_server_ms(response))
    return {
        "render_ms_p50": round(statistics.median(render), 2),
        "render_ms_p90": round(_percentile(render, 90), 2),
        "http_ms_p50": round(statistics.median(wall), 2),
        "http_ms_max": round(max(wall), 2),
    }


def measure(loads: int = LOADS) -> dict[str, Any]:
    folder = Path(tempfile.mkdtemp(prefix="dualsys-bench-dashboard-"))
    url = f"sqlite:///{folder / 'bench.db'}"
    filled = time.perf_counter()
    running_job = fill_database(url)
    long_job = add_long_run(url)
    filled = time.perf_counter() - filled
    port = _free_port()
    environment = {k: v for k, v in os.environ.items() if not k.startswith("DUALSYS_")}
    environment.update(
        DUALSYS_DATABASE_URL=url,
        DUALSYS_ARTIFACTS=str(folder / "artifacts"),
        DUALSYS_PORT=str(port),
        DUALSYS_RUN_JOBS="false",
        PYTHONPATH=os.pathsep.join([str(PROJECT_ROOT), os.environ.get("PYTHONPATH", "")]),
    )
    log = open(folder / "server.log", "wb")  # noqa: SIM115 - closed below
    server = subprocess.Popen(
        [sys.executable, "-m", "service.server"], env=environment, stdout=log, stderr=log
    )
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=60) as client:
            deadline = time.monotonic() + 60
            while True:
                try:
                    if client.get("/health").status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                if time.monotonic() > deadline or server.poll() is not None:
                    raise RuntimeError(f"the service did not start; see {folder / 'server.log'}")
                time.sleep(0.2)
            cold = client.get("/ui")
            jobs_load = _first_load(client, "/ui", ["/ui/jobs/rows?page=1"])
            jobs = _timed(client, "/ui", loads)
            deep = _timed(client, "/ui?status=succeeded&page=4", loads)
            rows = _timed(client, "/ui/jobs/rows?page=1", loads)
            job_path = f"/ui/jobs/{running_job}"
            # what job.js asks for first: the thinned series (all 1 000 records of this job)
            job_load = _first_load(client, job_path, [f"/jobs/{running_job}/series?points=1000"])
            job_page = _timed(client, job_path, loads)
            long_path = f"/ui/jobs/{long_job}"
            long_series = f"/jobs/{long_job}/series?points=1000"
            long_load = _first_load(client, long_path, [long_series])
            series_times = []
            for _ in range(max(3, loads // 4)):
                started = time.perf_counter()
                client.get(long_series).raise_for_status()
                series_times.append(1000 * (time.perf_counter() - started))
            full_bytes = sum(
                _wire_bytes(client.get(f"/jobs/{long_job}/metrics?since={since}&limit=10000"))
                for since in range(0, LONG_EPISODES, 10_000)
            )
            count = len(re.findall(r"<tr data-job-id=", cold.text))
        return {
            "jobs": JOBS,
            "rows_on_page": count,
            "loads": loads,
            "jobs_page_cold_render_ms": round(_server_ms(cold), 2),
            **{f"jobs_page_{k}": v for k, v in jobs.items()},
            "goal_render_ms_p50": 100,
            "jobs_page_first_load_bytes": jobs_load["bytes"],
            "goal_first_load_bytes": 500_000,
            "jobs_page_first_load_parts": jobs_load["parts"],
            **{f"filtered_page_4_{k}": v for k, v in deep.items()},
            **{f"rows_refresh_{k}": v for k, v in rows.items()},
            **{f"job_page_{k}": v for k, v in job_page.items()},
            "job_page_first_load_bytes": job_load["bytes"],
            "job_page_metric_rows": EPISODES,
            "long_run_episodes": LONG_EPISODES,
            "long_run_page_first_load_bytes": long_load["bytes"],
            "goal_long_run_first_load_bytes": 1_000_000,
            "long_run_page_first_load_parts": long_load["parts"],
            "long_run_series_ms_p50": round(statistics.median(series_times), 1),
            "long_run_every_episode_bytes": full_bytes,
            "fill_s": round(filled, 1),
            "cpu_count": os.cpu_count(),
            "load_average_1m": round(os.getloadavg()[0], 2),
        }
    finally:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
        log.close()
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    import json

    print(json.dumps(measure()))
