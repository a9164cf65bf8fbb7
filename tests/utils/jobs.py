"""Helpers for driving jobs over the REST API in tests."""

from __future__ import annotations

from typing import Any

import httpx

from tests.utils.live_service import wait_for

FINISHED = {"succeeded", "failed", "cancelled"}


def submit(client: httpx.Client, kind: str, **spec: Any) -> dict[str, Any]:
    response = client.post("/jobs", json={"kind": kind, "spec": spec})
    assert response.status_code == 202, response.text
    return response.json()


def job(client: httpx.Client, job_id: int) -> dict[str, Any]:
    response = client.get(f"/jobs/{job_id}")
    assert response.status_code == 200, response.text
    return response.json()


def wait_status(
    client: httpx.Client, job_id: int, statuses: set[str], timeout: float = 60.0
) -> dict[str, Any]:
    def reached() -> dict[str, Any] | None:
        current = job(client, job_id)
        return current if current["status"] in statuses else None

    return wait_for(reached, timeout=timeout, interval=0.1, what=f"job {job_id} to reach {sorted(statuses)}")


def wait_progress(client: httpx.Client, job_id: int, episode: int, timeout: float = 60.0) -> dict[str, Any]:
    def reached() -> dict[str, Any] | None:
        current = job(client, job_id)
        return (
            current if current["progress"]["episode"] >= episode and current["status"] == "running" else None
        )

    return wait_for(reached, timeout=timeout, interval=0.05, what=f"job {job_id} to reach episode {episode}")


def metrics(client: httpx.Client, job_id: int) -> list[dict[str, Any]]:
    response = client.get(f"/jobs/{job_id}/metrics", params={"limit": 10_000})
    assert response.status_code == 200, response.text
    return response.json()["data"]
