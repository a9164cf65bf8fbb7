"""End to end with the real trainer: submit a tiny train job over REST, follow its events to the
end, download its checkpoint, register it, point an alias at it; and a train job that survives a
kill -9 of its worker and a crash of the whole service with a continuous metric history."""

from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import os
import signal
import time
from collections.abc import Callable
from datetime import datetime

import torch

from tests.utils.experiment_files import TINY_NETS
from tests.utils.jobs import FINISHED, job, metrics, submit, wait_status
from tests.utils.live_service import LiveService, wait_for

TINY = {
    **TINY_NETS,
    "run.eval_every": 0,
    "run.eval_episodes": 1,
    "run.checkpoint_every": 1,
    "run.num_threads": 1,
    "agent.learning_starts": 5,
    "agent.batch_size": 8,
}


def _events(client, job_id: int) -> list[tuple[str, dict]]:  # type: ignore[no-untyped-def]
    events, name = [], ""
    with client.stream("GET", f"/jobs/{job_id}/events", timeout=120) as stream:
        for line in stream.iter_lines():
            if line.startswith("event: "):
                name = line.removeprefix("event: ")
            elif line.startswith("data: "):
                events.append((name, json.loads(line.removeprefix("data: "))))
    return events


def test_submit_follow_download_register_alias(start_service: Callable[..., LiveService]) -> None:
    service = start_service(workers=2)
    with service.client() as client:
        spec = {
            "algo": "ddpg",
            "reward": "sparse",
            "seed": 3,
            "episodes": 5,
            "overrides": {**TINY, "env.max_steps": 5},
        }
        created = submit(client, "train", **spec)
        assert created["resolved"]["config"]["run"]["episodes"] == 5
        assert created["resolved"]["config"]["env"]["reward_mode"] == "sparse"
        assert created["progress"]["total"] == 5
        events = _events(client, created["id"])
        assert events[-1][0] == "end" and events[-1][1]["status"] == "succeeded", events[-1]
        episodes = [data["episode"] for name, data in events if name == "metric"]
        assert episodes == [1, 2, 3, 4, 5]
        first = next(data for name, data in events if name == "metric")
        assert {"charts/episodic_return", "charts/success", "global_step"} <= set(first["data"])
        done = job(client, created["id"])
        assert done["summary"]["episodes"] == 5 and done["summary"]["seed"] == 3

        names = {a["name"] for a in client.get(f"/jobs/{created['id']}/artifacts").json()["data"]}
        assert {"checkpoints/best.pt", "checkpoints/latest.pt", "metrics.csv", "config.yaml"} <= names
        download = client.get(f"/jobs/{created['id']}/artifacts/checkpoints/best.pt")
        assert download.status_code == 200
        checkpoint = torch.load(io.BytesIO(download.content), weights_only=True)
        assert "policy" in checkpoint and checkpoint["config"]["run"]["seed"] == 3

        registered = client.post(
            "/policies/grasp/versions", json={"job_id": created["id"], "tags": {"note": "e2e"}}
        )
        assert registered.status_code == 201, registered.text
        version = registered.json()
        assert version["ref"] == "grasp@1" and version["source_job_id"] == created["id"]
        assert version["tags"] == {"job_kind": "train", "note": "e2e"}
        assert version["config"]["run"]["seed"] == 3 and version["metrics"]["episodes"] == 5
        aliased = client.put("/policies/grasp/aliases/champion", json={"version": 1})
        assert aliased.status_code == 200 and aliased.json()["aliases"] == ["champion"]
        resolved = client.get("/policies/grasp/versions/champion").json()
        assert resolved["version"] == 1
        best = next(a for a in resolved["artifacts"] if a["name"] == "checkpoints/best.pt")
        stored = client.get(best["url"])
        assert hashlib.sha256(stored.content).hexdigest() == best["sha256"]
        assert stored.content == download.content
        listing = client.get("/policies").json()
        assert listing["data"][0]["name"] == "grasp" and listing["data"][0]["aliases"] == {"champion": 1}

        # jobs that take a policy resolve name@alias to a fixed version at submission
        exported = submit(client, "export", policy="grasp@champion")
        assert exported["resolved"]["policy"] == "grasp@1"
        assert exported["resolved"]["checkpoint"].endswith("policies/grasp/v1/checkpoints/best.pt")
        evaluation = submit(client, "eval", policy="grasp@champion", trials=2, max_steps=3, domain="real")
        exported = wait_status(client, exported["id"], FINISHED, timeout=180)
        assert exported["status"] == "succeeded", exported
        assert exported["summary"]["attached_to"] == "grasp@1"
        onnx = client.get("/policies/grasp/versions/1").json()["artifacts"]
        assert any(a["name"] == "policy.onnx" and a["kind"] == "onnx" for a in onnx)
        evaluation = wait_status(client, evaluation["id"], FINISHED, timeout=180)
        assert evaluation["status"] == "succeeded", evaluation
        assert evaluation["summary"]["trials"] == 2 and 0.0 <= evaluation["summary"]["success_rate"] <= 1.0
        pairs = service.folder / "pairs"
        from sim2real import generate_pairs

        generate_pairs(n=12, out=pairs, seed=0)
        aligned = submit(client, "align", policy="grasp@1", pairs_dir=str(pairs), epochs=2, batch_size=4)
        aligned = wait_status(client, aligned["id"], FINISHED, timeout=180)
        assert aligned["status"] == "succeeded", aligned
        assert aligned["summary"]["registered"] == "grasp-aligned@1"
        lineage = client.get("/policies/grasp-aligned/versions/1").json()
        assert lineage["parent"] == "grasp@1" and lineage["source_job_id"] == aligned["id"]

        # errors name the reason
        assert client.put("/policies/grasp/aliases/champion", json={"version": 7}).status_code == 404
        assert client.put("/policies/grasp/aliases/latest", json={"version": 1}).status_code == 422
        assert client.get("/policies/nope").status_code == 404
        unfinished = submit(client, "probe", episodes=100, interval_s=0.05)
        conflict = client.post("/policies/grasp/versions", json={"job_id": unfinished["id"]})
        assert conflict.status_code == 409 and "only a succeeded job" in conflict.json()["detail"]
        client.post(f"/jobs/{unfinished['id']}/cancel")


def test_train_job_survives_worker_kill_and_service_crash(start_service: Callable[..., LiveService]) -> None:
    service = start_service()
    episodes = 40  # room for both interruptions even when polling lags on a busy machine
    spec = {"algo": "ddpg", "episodes": episodes, "overrides": {**TINY, "env.max_steps": 20}}
    with service.client() as client:
        created = submit(client, "train", **spec)

        def at_least(episode: int, attempt: int) -> Callable[[], dict | None]:
            def check() -> dict | None:
                current = job(client, created["id"])
                ok = current["attempt"] == attempt and current["progress"]["episode"] >= episode
                return current if ok and current["status"] == "running" else None

            return check

        first = wait_for(at_least(5, 1), timeout=120, interval=0.05, what="attempt 1 at episode 5")
        os.kill(first["worker_pid"], signal.SIGKILL)
        second = wait_for(
            at_least(first["progress"]["episode"] + 5, 2), timeout=120, interval=0.05, what="attempt 2"
        )
        assert second["resume"] is True
    service.kill()
    wait_for(lambda: not os.path.exists(f"/proc/{second['worker_pid']}"), timeout=10, what="worker to die")
    service.start()
    with service.client() as client:
        done = wait_status(client, created["id"], FINISHED, timeout=180)
        assert done["status"] == "succeeded" and done["attempt"] == 3, done
        rows = metrics(client, created["id"])
        assert [r["episode"] for r in rows] == list(range(1, episodes + 1))
        assert {r["attempt"] for r in rows} == {1, 2, 3}
        steps = [r["global_step"] for r in rows]
        assert steps == sorted(steps) and len(set(steps)) == episodes  # one continuous run
        # the trainer's own metrics.csv agrees: every episode exactly once
        text = client.get(f"/jobs/{created['id']}/artifacts/metrics.csv").text
        assert [int(float(r["episode"])) for r in csv.DictReader(io.StringIO(text))] == list(
            range(1, episodes + 1)
        )


def test_service_crash_loses_at_most_the_time_checkpoint_interval(
    start_service: Callable[..., LiveService],
) -> None:
    """kill -9 of the service 30 episodes into a train job whose checkpoints come only by time
    (`run.checkpoint_every_s`; by episode every 1000): the restarted job resumes past its first
    checkpoint, and the work lost is what ran after the last one, measured here in episodes and seconds."""
    every_s = 1.0
    episodes = 45
    overrides = {**TINY, "env.max_steps": 20, "run.checkpoint_every": 1000, "run.checkpoint_every_s": every_s}
    service = start_service()
    with service.client() as client:
        created = submit(client, "train", algo="ddpg", episodes=episodes, overrides=overrides)
        before = wait_for(
            lambda: (j := job(client, created["id"]))["progress"]["episode"] >= 30 and j,
            timeout=180,
            interval=0.05,
            what="the job at episode 30",
        )
    service.kill()
    killed_at = time.time()
    service.start()
    with service.client() as client:
        done = wait_status(client, created["id"], FINISHED, timeout=240)
        assert done["status"] == "succeeded" and done["attempt"] == 2, done
        rows = metrics(client, created["id"])
    assert [r["episode"] for r in rows] == list(range(1, episodes + 1))  # exactly once
    resumed_at = min(r["episode"] for r in rows if r["attempt"] == 2)
    assert resumed_at > 1, "the job started over instead of resuming from its time checkpoint"
    kept = [r for r in rows if r["attempt"] == 1]
    assert [r["episode"] for r in kept] == list(range(1, resumed_at))
    reached = max(before["progress"]["episode"], resumed_at - 1)
    lost_episodes = reached - (resumed_at - 1)
    recorded = [datetime.fromisoformat(r["recorded_at"]).timestamp() for r in kept]
    lost_s = killed_at - recorded[-1]
    durations = [b - a for a, b in itertools.pairwise(recorded)]
    print(
        f"\ncrash at episode >= {before['progress']['episode']}: resumed at episode {resumed_at}, "
        f"lost {lost_episodes}+ episodes and {lost_s:.2f} s of training "
        f"(checkpoint_every_s={every_s}, episodes took {min(durations):.2f}-{max(durations):.2f} s)"
    )
    # a checkpoint is written at the first episode end `every_s` after the last one, so the work lost
    # is under every_s plus one episode, plus the time between the observation and the kill
    assert lost_s < every_s + max(durations) + 2.0, (lost_s, durations)
