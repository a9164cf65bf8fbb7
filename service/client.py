"""A small HTTP client of the job service (httpx), used by `dualsys jobs` and the benchmark.

Errors the service answers (4xx/5xx JSON) and unreachable URLs become `ServiceCallError`
(a ValueError: the CLI prints its one line and exits 2).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from typing import Any

import httpx

DEFAULT_URL = "http://127.0.0.1:8000"


class ServiceCallError(ValueError):
    """The service refused a request (its JSON `detail` is the message) or could not be reached."""

    def __init__(self, message: str, status_code: int | None = None) -> None:
        super().__init__(message)
        self.status_code = status_code


class ServiceClient:
    def __init__(self, url: str | None = None, token: str | None = None, timeout: float = 30.0) -> None:
        self.url = (url or os.environ.get("DUALSYS_URL") or DEFAULT_URL).rstrip("/")
        token = token if token is not None else os.environ.get("DUALSYS_TOKEN")
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self._http = httpx.Client(base_url=self.url, headers=headers, timeout=timeout)

    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> ServiceClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _call(self, method: str, path: str, **kwargs: Any) -> Any:
        try:
            response = self._http.request(method, path, **kwargs)
        except httpx.HTTPError as error:
            raise ServiceCallError(f"cannot reach the dualsys service at {self.url}: {error}") from error
        if response.status_code >= 400:
            try:
                detail = response.json().get("detail", response.text)
            except ValueError:
                detail = response.text or response.reason_phrase
            raise ServiceCallError(f"{detail} (HTTP {response.status_code})", response.status_code)
        return response.json() if response.content else None

    # jobs
    def submit(self, kind: str, spec: dict[str, Any]) -> dict[str, Any]:
        return self._call("POST", "/jobs", json={"kind": kind, "spec": spec})

    def list_jobs(
        self,
        *,
        status: str | None = None,
        kind: str | None = None,
        offset: int = 0,
        limit: int = 50,
        experiment_id: int | None = None,
    ) -> dict[str, Any]:
        given = {
            "status": status,
            "kind": kind,
            "offset": offset,
            "limit": limit,
            "experiment_id": experiment_id,
        }
        return self._call("GET", "/jobs", params={k: v for k, v in given.items() if v})

    def job(self, job_id: int) -> dict[str, Any]:
        return self._call("GET", f"/jobs/{job_id}")

    def cancel(self, job_id: int) -> dict[str, Any]:
        return self._call("POST", f"/jobs/{job_id}/cancel")

    def metrics(self, job_id: int, since: int = 0) -> dict[str, Any]:
        return self._call("GET", f"/jobs/{job_id}/metrics", params={"since": since})

    def events(self, job_id: int, since: int = 0) -> Iterator[tuple[str, dict[str, Any]]]:
        """Yield (event, data) from the job's server-sent event stream until its `end` event."""
        try:
            with self._http.stream(
                "GET", f"/jobs/{job_id}/events", params={"since": since}, timeout=None
            ) as stream:
                if stream.status_code >= 400:
                    stream.read()
                    raise ServiceCallError(
                        f"{stream.json().get('detail', stream.text)} (HTTP {stream.status_code})",
                        stream.status_code,
                    )
                name = "message"
                for line in stream.iter_lines():
                    if line.startswith("event: "):
                        name = line.removeprefix("event: ")
                    elif line.startswith("data: "):
                        yield name, json.loads(line.removeprefix("data: "))
                        name = "message"
        except httpx.HTTPError as error:
            raise ServiceCallError(f"lost the event stream of job {job_id}: {error}") from error

    # registry
    def register(self, name: str, job_id: int, **fields: Any) -> dict[str, Any]:
        return self._call("POST", f"/policies/{name}/versions", json={"job_id": job_id, **fields})

    def set_alias(self, name: str, alias: str, version: int) -> dict[str, Any]:
        return self._call("PUT", f"/policies/{name}/aliases/{alias}", json={"version": version})

    # experiments
    def submit_experiment(self, content: str, workers: int = 1) -> dict[str, Any]:
        return self._call("POST", "/experiments", json={"content": content, "workers": workers})

    def experiment(self, experiment_id: int, *, report: bool = True) -> dict[str, Any]:
        params = {"report": "true" if report else "false"}
        return self._call("GET", f"/experiments/{experiment_id}", params=params)

    def cancel_experiment(self, experiment_id: int) -> dict[str, Any]:
        return self._call("POST", f"/experiments/{experiment_id}/cancel")

    def artifact(self, job_id: int, name: str) -> bytes:
        """The bytes of one file of a job's run directory."""
        try:
            response = self._http.get(f"/jobs/{job_id}/artifacts/{name}")
        except httpx.HTTPError as error:
            raise ServiceCallError(f"cannot reach the dualsys service at {self.url}: {error}") from error
        if response.status_code >= 400:
            raise ServiceCallError(f"job {job_id} has no file {name} (HTTP {response.status_code})")
        return response.content
