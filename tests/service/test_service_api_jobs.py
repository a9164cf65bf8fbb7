"""The jobs API against a real server: auth, validation, cancel, delete, limits, downloads, SSE."""

from __future__ import annotations

import json
import os
import socket
from collections.abc import Iterator

import httpx
import pytest

from tests.utils.jobs import FINISHED, job, metrics, submit, wait_progress, wait_status
from tests.utils.live_service import LiveService, wait_for


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveService]:
    live = LiveService(tmp_path_factory.mktemp("api"), workers=4, max_request_bytes=4096).start()
    yield live
    live.kill()


@pytest.fixture()
def client(service: LiveService) -> Iterator[httpx.Client]:
    with service.client() as authorised:
        yield authorised


def test_probe_job_runs_in_its_own_process_and_records_metrics(client: httpx.Client) -> None:
    created = submit(client, "probe", episodes=4, interval_s=0.05)
    assert created["status"] == "queued" and created["id"] >= 1
    done = wait_status(client, created["id"], FINISHED)
    assert done["status"] == "succeeded", done
    assert done["summary"] == {"episodes": 4, "resumed": False}
    rows = metrics(client, created["id"])
    assert [r["episode"] for r in rows] == [1, 2, 3, 4]
    worker_pids = {r["data"]["probe/pid"] for r in rows}
    assert len(worker_pids) == 1 and os.getpid() not in worker_pids
    since = client.get(f"/jobs/{created['id']}/metrics", params={"since": 2}).json()
    assert [r["episode"] for r in since["data"]] == [3, 4]
    artifacts = {a["name"] for a in client.get(f"/jobs/{created['id']}/artifacts").json()["data"]}
    assert {"checkpoints/latest.json", "summary.json"} <= artifacts
    download = client.get(f"/jobs/{created['id']}/artifacts/checkpoints/latest.json")
    assert download.status_code == 200 and json.loads(download.content) == {"episode": 4}


def test_unauthenticated_mutations_get_401(service: LiveService) -> None:
    with service.client(auth=False) as anonymous:
        body = {"kind": "probe", "spec": {}}
        for method, path, payload in [
            ("POST", "/jobs", body),
            ("POST", "/jobs/1/cancel", None),
            ("DELETE", "/jobs/1", None),
            ("POST", "/policies/grasp/versions", {"job_id": 1}),
            ("PUT", "/policies/grasp/aliases/champion", {"version": 1}),
        ]:
            response = anonymous.request(method, path, json=payload)
            assert response.status_code == 401, (method, path, response.text)
            assert "bearer token" in response.json()["detail"]
            assert response.headers["www-authenticate"] == "Bearer"
        wrong = anonymous.post("/jobs", json=body, headers={"Authorization": "Bearer wrong"})
        assert wrong.status_code == 401
        assert anonymous.get("/jobs").status_code == 200  # reads stay open


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"kind": "train", "spec": {"episodes": 0}}, "spec.episodes"),
        ({"kind": "train", "spec": {"reward": "medium"}}, "spec.reward"),
        ({"kind": "train", "spec": {"algo": "nope"}}, "spec.algo"),
        ({"kind": "train", "spec": {"overrides": {"agent.nope": 1}}}, "spec.overrides"),
        ({"kind": "train", "spec": {"overrides": {"agent.batch_size": "many"}}}, "spec.overrides"),
        ({"kind": "train", "spec": {"colour": "red"}}, "spec.colour"),
        ({"kind": "train", "spec": {"ac": "sgd"}}, "spec.ac"),
        ({"kind": "train", "spec": {"profile": "fastest"}}, "spec.profile"),
        ({"kind": "eval", "spec": {"trials": 3}}, "spec.policy"),
        ({"kind": "eval", "spec": {"policy": "bad name@x"}}, "spec.policy"),
        ({"kind": "export", "spec": {"policy": "p", "out": "../x.onnx"}}, "spec.out"),
        ({"kind": "probe", "spec": {"episodes": "2"}}, "spec.episodes"),  # JSON types are not converted
        ({"kind": "probe", "spec": {"interval_s": False}}, "spec.interval_s"),
        ({"kind": "train", "spec": {"overrides": {"agent.batch_size": "32"}}}, "spec.overrides"),
        ({"kind": "train", "spec": {"overrides": {"agent.batch_size": 0}}}, "spec.overrides"),
        ({"kind": "train", "spec": {"overrides": {"env.level": "hard", "env.hand": "auto"}}}, "spec"),
        ({"kind": "dance", "spec": {}}, "kind"),
        ({"spec": {}}, "kind"),
    ],
)
def test_bad_specs_get_422_naming_the_field(client: httpx.Client, body: dict, field: str) -> None:
    response = client.post("/jobs", json=body)
    assert response.status_code == 422, response.text
    payload = response.json()
    assert payload["detail"].startswith(field), payload
    assert payload["errors"] and payload["errors"][0]["field"].startswith(field)


@pytest.mark.parametrize(
    ("body", "status", "field"),
    [
        ({"kind": "eval", "spec": {"policy": "unknown@1"}}, 404, "spec.policy"),
        ({"kind": "align", "spec": {"policy": "p@1", "pairs_dir": "/no/such/dir"}}, 404, "spec.pairs_dir"),
    ],
)
def test_specs_naming_what_the_service_lacks_get_404(
    client: httpx.Client, body: dict, status: int, field: str
) -> None:
    """A schema-valid spec is never a 422: a policy or folder that is not there is a 404, as for a path."""
    response = client.post("/jobs", json=body)
    assert response.status_code == status, response.text
    assert response.json()["detail"].startswith(field)


def test_integral_numbers_are_integers_as_in_json_schema(client: httpx.Client) -> None:
    created = client.post("/jobs", json={"kind": "probe", "spec": {"episodes": 2.0, "interval_s": 0}})
    assert created.status_code == 202, created.text
    assert created.json()["spec"]["episodes"] == 2
    # beyond `episodes` the run ends first: no longer a 422 the schema could not state
    later = client.post("/jobs", json={"kind": "probe", "spec": {"episodes": 1, "fail_at_episode": 5}})
    assert later.status_code == 202, later.text
    assert wait_status(client, later.json()["id"], FINISHED)["status"] == "succeeded"


@pytest.mark.parametrize(
    ("path", "allowed"),
    [
        ("/jobs", "GET, POST"),
        ("/jobs/1", "DELETE, GET"),
        ("/experiments", "GET, POST"),
        ("/experiments/1", "DELETE, GET"),
        ("/policies/grasp/aliases/champion", "DELETE, PUT"),
    ],
)
def test_405_names_every_method_of_the_path(client: httpx.Client, path: str, allowed: str) -> None:
    response = client.request("PATCH", path)
    assert response.status_code == 405
    assert response.headers["allow"] == allowed
    assert response.json()["detail"] == "Method Not Allowed"


def test_malformed_json_and_oversized_bodies(client: httpx.Client) -> None:
    broken = client.post("/jobs", content=b"{not json", headers={"Content-Type": "application/json"})
    assert broken.status_code == 422 and broken.json()["detail"]
    big = {"kind": "train", "spec": {"overrides": {f"agent.k{i}": "x" * 50 for i in range(200)}}}
    too_large = client.post("/jobs", json=big)
    assert too_large.status_code == 413 and "larger than 4096 bytes" in too_large.json()["detail"]

    def chunks() -> Iterator[bytes]:
        yield b'{"kind": "probe", "spec": {}, "pad": "'
        for _ in range(10):
            yield b"x" * 1000
        yield b'"}'

    chunked = client.post("/jobs", content=chunks(), headers={"Content-Type": "application/json"})
    assert chunked.status_code == 413


def test_not_found_and_conflicts(client: httpx.Client) -> None:
    assert client.get("/jobs/999999").status_code == 404
    assert client.get("/jobs/999999").json()["detail"] == "no job with id 999999"
    assert client.post("/jobs/999999/cancel").status_code == 404
    finished = submit(client, "probe", episodes=1, interval_s=0)
    wait_status(client, finished["id"], FINISHED)
    conflict = client.post(f"/jobs/{finished['id']}/cancel")
    assert conflict.status_code == 409 and "already succeeded" in conflict.json()["detail"]
    deleted = client.delete(f"/jobs/{finished['id']}")
    assert deleted.status_code == 204
    assert client.get(f"/jobs/{finished['id']}").status_code == 404


def test_cancel_queued_and_running_jobs(service: LiveService, client: httpx.Client) -> None:
    running = submit(client, "probe", episodes=1000, interval_s=0.05)
    wait_progress(client, running["id"], 2)
    pid = job(client, running["id"])["worker_pid"]
    assert pid and pid != os.getpid()
    assert client.delete(f"/jobs/{running['id']}").status_code == 409  # not finished yet
    response = client.post(f"/jobs/{running['id']}/cancel")
    assert response.status_code == 202 and response.json()["cancel_requested"] is True
    cancelled = wait_status(client, running["id"], FINISHED, timeout=20)
    assert cancelled["status"] == "cancelled"
    wait_for(lambda: not os.path.exists(f"/proc/{pid}") or _zombie(pid), timeout=10, what="worker exit")
    # a queued job is cancelled at once, before any worker sees it
    with service.client() as other:
        blockers = [submit(other, "probe", episodes=40, interval_s=0.05) for _ in range(4)]
        queued = submit(other, "probe", episodes=5)
        answer = other.post(f"/jobs/{queued['id']}/cancel").json()
        assert answer["status"] == "cancelled" and answer["attempt"] == 0
        for blocker in blockers:
            other.post(f"/jobs/{blocker['id']}/cancel")
        for blocker in blockers:
            wait_status(other, blocker["id"], FINISHED)


def _zombie(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split()[2] == "Z"
    except OSError:
        return True


def test_failing_job_is_failed_with_its_reason(client: httpx.Client) -> None:
    created = submit(client, "probe", episodes=3, interval_s=0, fail_at_episode=2)
    done = wait_status(client, created["id"], FINISHED)
    assert done["status"] == "failed"
    assert done["reason"] == "ProbeFailure: probe failed at episode 2 as its spec asked"
    assert [r["episode"] for r in metrics(client, created["id"])] == [1]


def test_listing_filters_and_pages(client: httpx.Client) -> None:
    ids = [submit(client, "probe", episodes=1, interval_s=0)["id"] for _ in range(3)]
    for job_id in ids:
        wait_status(client, job_id, FINISHED)
    page = client.get("/jobs", params={"kind": "probe", "status": "succeeded", "limit": 2}).json()
    assert len(page["data"]) == 2 and page["count"] >= 3
    assert all(j["kind"] == "probe" and j["status"] == "succeeded" for j in page["data"])
    assert page["data"][0]["id"] > page["data"][1]["id"]  # newest first
    second = client.get(
        "/jobs", params={"kind": "probe", "status": "succeeded", "limit": 2, "offset": 2}
    ).json()
    assert not {j["id"] for j in second["data"]} & {j["id"] for j in page["data"]}
    assert client.get("/jobs", params={"status": "sleeping"}).status_code == 422
    assert client.get("/jobs", params={"limit": 0}).json()["detail"].startswith("limit")


def test_idempotency_key_replays_the_first_job(client: httpx.Client) -> None:
    body = {"kind": "probe", "spec": {"episodes": 1, "interval_s": 0}}
    first = client.post("/jobs", json=body, headers={"Idempotency-Key": "abc-123"})
    again = client.post("/jobs", json=body, headers={"Idempotency-Key": "abc-123"})
    assert first.status_code == 202 and again.status_code == 200
    assert first.json()["id"] == again.json()["id"]


@pytest.mark.parametrize(
    "attack",
    [
        "%2e%2e/%2e%2e/%2e%2e/dualsys.db",
        "%2e%2e%2f%2e%2e%2f%2e%2e%2fdualsys.db",
        "..%2f..%2f..%2fdualsys.db",
        "%252e%252e%252f%252e%252e%252f%252e%252e%252fdualsys.db",
        "%2fetc%2fpasswd",
        "..%5c..%5c..%5cdualsys.db",
        ".hidden",
    ],
)
def test_artifact_downloads_cannot_leave_the_run_directory(client: httpx.Client, attack: str) -> None:
    created = submit(client, "probe", episodes=1, interval_s=0)
    wait_status(client, created["id"], FINISHED)
    response = client.get(httpx.URL(f"{client.base_url}/jobs/{created['id']}/artifacts/{attack}"))
    # a name outside the schema's pattern is a 422; one inside it that is not there a 404
    assert response.status_code in (400, 404, 422), response.text
    assert b"SQLite" not in response.content and b"root:" not in response.content
    assert response.headers["content-type"] == "application/json"


def test_literal_dot_dot_in_the_raw_request_line(service: LiveService) -> None:
    """httpx normalises `..` away, so send the raw request line over a socket."""
    with socket.create_connection(("127.0.0.1", service.port), timeout=5) as raw:
        raw.sendall(
            b"GET /jobs/1/artifacts/../../../dualsys.db HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
        )
        reply = b""
        while chunk := raw.recv(65536):
            reply += chunk
    status_line = reply.split(b"\r\n", 1)[0]
    assert b" 200 " not in status_line or b"SQLite format" not in reply
    assert b"SQLite format" not in reply


def test_event_stream_reports_status_metrics_and_end(client: httpx.Client) -> None:
    created = submit(client, "probe", episodes=3, interval_s=0.1)
    events: list[tuple[str, str | None, dict]] = []
    with client.stream("GET", f"/jobs/{created['id']}/events", timeout=30) as stream:
        assert stream.headers["content-type"].startswith("text/event-stream")
        name, event_id = None, None
        for line in stream.iter_lines():
            if line.startswith("event: "):
                name = line.removeprefix("event: ")
            elif line.startswith("id: "):
                event_id = line.removeprefix("id: ")
            elif line.startswith("data: "):
                events.append((name or "", event_id, json.loads(line.removeprefix("data: "))))
                name, event_id = None, None
    kinds = [e[0] for e in events]
    assert kinds[0] == "status" and kinds[-1] == "end"
    metric_events = [e for e in events if e[0] == "metric"]
    assert [e[2]["episode"] for e in metric_events] == [1, 2, 3]
    assert [e[1] for e in metric_events] == ["1", "2", "3"]
    assert events[-1][2]["status"] == "succeeded"
    # reconnecting with Last-Event-ID replays only what came after
    with client.stream(
        "GET", f"/jobs/{created['id']}/events", headers={"Last-Event-ID": "2"}, timeout=30
    ) as stream:
        replay = [json.loads(line[6:]) for line in stream.iter_lines() if line.startswith("data: ")]
    assert [e["episode"] for e in replay if "episode" in e and "kind" not in e] == [3]


def test_health_and_openapi(client: httpx.Client) -> None:
    health = client.get("/health").json()
    assert health["status"] == "ok" and health["database"] == "sqlite" and health["executor"] == "local"
    schema = client.get("/openapi.json").json()
    assert {"/jobs", "/jobs/{job_id}/events", "/policies/{name}/aliases/{alias}", "/health"} <= set(
        schema["paths"]
    )
    assert client.get("/docs").status_code == 200


def test_records_are_committed_before_the_job_checkpoints_them(
    service: LiveService, client: httpx.Client
) -> None:
    """Sampled invariant: whenever the checkpoint says episode k, the database already holds row k."""
    created = submit(client, "probe", episodes=30, interval_s=0.02)
    checkpoint = service.artifacts / "jobs" / str(created["id"]) / "checkpoints" / "latest.json"
    samples = 0
    while job(client, created["id"])["status"] in ("queued", "running"):
        try:
            episode = json.loads(checkpoint.read_text())["episode"]
        except (OSError, ValueError):
            continue
        stored = len(metrics(client, created["id"]))
        assert stored >= episode, (stored, episode)
        samples += 1
    assert samples > 0
