"""50 concurrent submissions to two services sharing one database: 50 jobs, each run exactly once."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import httpx

from tests.utils.jobs import metrics
from tests.utils.live_service import LiveService, wait_for


def test_fifty_concurrent_submissions_run_exactly_once(start_service: Callable[..., LiveService]) -> None:
    first = start_service("a", workers=2)
    second = LiveService(first.folder.parent / "b", workers=2)
    second.settings.update(database_url=first.settings["database_url"], artifacts=first.settings["artifacts"])
    try:
        second.start()
        urls = [first.url, second.url]

        def post(index: int) -> int:
            headers = {"Authorization": f"Bearer {first.token}"}
            with httpx.Client(base_url=urls[index % 2], headers=headers, timeout=60) as client:
                response = client.post(
                    "/jobs", json={"kind": "probe", "spec": {"episodes": 1, "interval_s": 0}}
                )
                assert response.status_code == 202, response.text
                return response.json()["id"]

        with ThreadPoolExecutor(max_workers=50) as pool:
            ids = list(pool.map(post, range(50)))
        assert sorted(ids) == list(range(1, 51))  # fifty rows, no duplicate, none lost

        with first.client() as client:

            def all_succeeded() -> bool:
                return client.get("/jobs", params={"status": "succeeded"}).json()["count"] == 50

            wait_for(all_succeeded, timeout=150, interval=0.5, what="50 jobs to succeed")
            jobs = client.get("/jobs", params={"limit": 100}).json()["data"]
            assert len(jobs) == 50
            assert all(j["attempt"] == 1 for j in jobs)  # claimed once, never re-run
            pids = set()
            for job_id in ids:
                rows = metrics(client, job_id)
                assert [r["episode"] for r in rows] == [1]
                pids.add(rows[0]["data"]["probe/pid"])
            assert len(pids) == 50  # one process per job
    finally:
        second.kill()
