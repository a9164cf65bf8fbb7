"""Experiments as jobs, against a real service: an experiment file's cells run as train jobs (at most
`workers` at a time), the report's numbers equal the library's report on the same run directories
(and `dualsys experiments report` writes the same), a crash mid-experiment completes every cell exactly
once, cancel stops the unfinished cells and DELETE removes a finished experiment, and bad files are 422s
naming the key (an empty one as the OpenAPI schema says: `minLength: 1`)."""

from __future__ import annotations

import json
from collections.abc import Callable
from datetime import datetime
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from core.experiments import build_report
from tests.utils.experiment_files import TINY_CELL_OVERRIDES
from tests.utils.jobs import FINISHED, job, metrics
from tests.utils.live_service import LiveService, wait_for


def _experiment(name: str, *, methods: list[dict], seeds: int, steps: int, **extra) -> str:  # type: ignore[no-untyped-def]
    data = {
        "name": name,
        "rewards": ["sparse"],
        "seeds": seeds,
        "steps": steps,
        "eval_every": 0,
        "eval_episodes": 1,
        "overrides": TINY_CELL_OVERRIDES,
        "methods": methods,
        **extra,
    }
    return yaml.safe_dump(data, sort_keys=False)


def _plain(value: object) -> object:
    """As JSON carries it: NaN (a score no seed has) as null."""
    return json.loads(json.dumps(value), parse_constant=lambda _: None)


def _wait_finished(client, experiment_id: int, timeout: float) -> dict:  # type: ignore[no-untyped-def]
    def finished() -> dict | None:
        current = client.get(f"/experiments/{experiment_id}", params={"report": "false"}).json()
        return current if current["cells"]["queued"] == 0 and current["cells"]["running"] == 0 else None

    return wait_for(finished, timeout=timeout, interval=0.5, what=f"experiment {experiment_id} to finish")


@pytest.mark.timeout(1800)  # each cell process imports torch and PyBullet: minutes on a loaded machine
def test_experiment_cells_run_as_jobs_and_report_like_the_library(
    start_service: Callable[..., LiveService], tmp_path: Path
) -> None:
    service = start_service(workers=2)
    content = _experiment(
        "tiny",
        methods=[{"label": "DDPG", "algo": "ddpg"}, {"label": "CACLA", "algo": "cacla"}],
        seeds=1,
        steps=40,
        baseline="DDPG",
    )
    with service.client(timeout=180) as client:
        response = client.post("/experiments", json={"content": content, "workers": 1})
        assert response.status_code == 202, response.text
        created = response.json()
        cells = created["cells"]
        # a worker may claim the first job between the insert and the answer: queued or running, both new
        assert (cells["total"], cells["done"], cells["failed"], cells["cancelled"]) == (2, 0, 0, 0), cells
        assert cells["queued"] + cells["running"] == 2, cells
        assert [j["cell"] for j in created["jobs"]] == ["DDPG/sparse/seed-0", "CACLA/sparse/seed-0"]
        done = _wait_finished(client, created["id"], timeout=1500)
        assert done["status"] == "succeeded" and done["cells"]["done"] == 2, done
        # the report is computed in the background once per set of finished cells
        shown = wait_for(
            lambda: (
                (e := client.get(f"/experiments/{created['id']}").json())["report"]
                and e["report"]["done"] == 2
                and not e["report_pending"]
                and e
            ),
            timeout=900,
            interval=1.0,
            what="the report of both cells",
        )
        jobs = [job(client, j["job_id"]) for j in shown["jobs"]]

    # every cell is an ordinary train job in the experiment's folder; one at a time (workers: 1), though
    # the service had two slots
    assert {j["kind"] for j in jobs} == {"train"} and all(j["attempt"] == 1 for j in jobs)
    spans = [
        (datetime.fromisoformat(j["started_at"]), datetime.fromisoformat(j["finished_at"])) for j in jobs
    ]
    overlap = max(sum(1 for s, e in spans if s <= start < e) for start, _ in spans)
    assert overlap == 1, spans

    # the service's report numbers are the library's report of the same run directories
    folder = service.artifacts / "experiments" / str(created["id"]) / "tiny"
    assert (folder / "experiment.yaml").is_file()
    assert _plain(shown["report"]) == _plain(build_report(folder))
    assert shown["report"]["done"] == 2 and shown["report"]["missing"] == []
    assert shown["report"]["methods"]["CACLA"]["sparse"]["baseline"] == "DDPG"

    # `dualsys experiments report` downloads the cells and writes the same numbers and the figures
    environment = {"DUALSYS_URL": service.url, "DUALSYS_TOKEN": service.token or ""}
    from dualsys_cli.main import app

    result = CliRunner().invoke(
        app, ["experiments", "report", str(created["id"]), "--out", str(tmp_path / "out")], env=environment
    )
    assert result.exit_code == 0, result.output
    written = tmp_path / "out" / "tiny"
    assert {"report.md", "learning_curves.png", "scores.png"} <= {p.name for p in written.iterdir()}
    local = json.loads((written / "report.json").read_text())
    for label in ("DDPG", "CACLA"):
        assert _plain(local["methods"][label]) == _plain(shown["report"]["methods"][label])


@pytest.mark.timeout(1800)
def test_crash_mid_experiment_completes_every_cell_exactly_once(
    start_service: Callable[..., LiveService],
) -> None:
    service = start_service(workers=1)
    content = _experiment(
        "restart",
        methods=[{"label": "DDPG", "algo": "ddpg"}],
        seeds=2,
        steps=100,
        overrides={**TINY_CELL_OVERRIDES, "run.checkpoint_every": 1},
    )
    with service.client(timeout=180) as client:
        created = client.post("/experiments", json={"content": content, "workers": 1}).json()
        first = created["jobs"][0]["job_id"]
        wait_for(
            lambda: job(client, first)["progress"]["episode"] >= 3,
            timeout=900,
            interval=0.1,
            what="the first cell at episode 3",
        )
    service.kill()
    service.start()
    with service.client(timeout=180) as client:
        done = _wait_finished(client, created["id"], timeout=1500)
        assert done["cells"]["done"] == 2, done
        for cell in done["jobs"]:
            rows = metrics(client, cell["job_id"])
            episodes = [r["episode"] for r in rows]
            assert episodes == list(range(1, len(episodes) + 1)) and episodes, cell
            steps = [r["global_step"] for r in rows]
            assert steps == sorted(steps) and steps[-1] >= 100  # one continuous run to the budget
        assert job(client, first)["attempt"] == 2  # the crashed cell ran again, resumed
        resumed = [r for r in metrics(client, first) if r["attempt"] == 2]
        assert resumed[0]["episode"] > 1  # from its checkpoint, not from the start


@pytest.mark.timeout(900)
def test_cancel_then_delete_and_bad_files_are_422(
    start_service: Callable[..., LiveService],
) -> None:
    service = start_service(workers=1)
    with service.client(timeout=180) as client:
        bad = {
            "name: x\n": "content.methods",  # missing key
            "nope: 1\n": "content.nope",  # unknown key
            _experiment("x", methods=[{"label": "A", "algo": "nope"}], seeds=1, steps=10): (
                "content.methods[0].algo"
            ),
            _experiment("x", methods=[{"label": "A", "algo": "ddpg"}], seeds=0, steps=10): "content.seeds",
            "[1, 2": "content",  # not YAML
            "smoke.yaml": "content",  # a file name is not a file's content (never read on the server)
        }
        for content, field in bad.items():
            response = client.post("/experiments", json={"content": content})
            assert response.status_code == 422, (content, response.text)
            body = response.json()
            assert body["errors"][0]["field"] == field, (content, body)
            assert body["detail"].startswith("content"), body
        response = client.post("/experiments", json={"content": "name: x\n", "workers": 0})
        assert response.status_code == 422 and response.json()["errors"][0]["field"] == "workers"
        assert client.get("/experiments", params={"limit": 5}).json()["count"] == 0  # nothing was queued
        assert client.get("/experiments/99").status_code == 404

        content = _experiment("long", methods=[{"label": "A", "algo": "ddpg"}], seeds=3, steps=100_000)
        created = client.post("/experiments", json={"content": content, "workers": 1}).json()
        unauthorised = service.client(auth=False).post(f"/experiments/{created['id']}/cancel")
        assert unauthorised.status_code == 401
        assert client.delete(f"/experiments/{created['id']}").status_code == 409  # cells unfinished
        cancelled = client.post(f"/experiments/{created['id']}/cancel")
        assert cancelled.status_code == 202 and cancelled.json()["cancel_requested"] is True
        done = _wait_finished(client, created["id"], timeout=600)
        assert done["status"] == "cancelled" and done["cells"]["cancelled"] == 3, done
        assert all(job(client, j["job_id"])["status"] in FINISHED for j in done["jobs"])
        cells = client.get("/jobs", params={"experiment_id": created["id"]}).json()
        assert sorted(j["id"] for j in cells["data"]) == sorted(j["job_id"] for j in done["jobs"])
        # DELETE removes a finished experiment: its row, its cells' jobs and its folder
        folder = service.artifacts / "experiments" / str(created["id"])
        assert folder.is_dir()
        assert client.delete(f"/experiments/{created['id']}").status_code == 204
        assert client.get(f"/experiments/{created['id']}").status_code == 404
        assert client.get("/jobs", params={"experiment_id": created["id"]}).json()["count"] == 0
        assert not folder.exists()


def test_an_empty_file_is_refused_as_the_schema_says(start_service: Callable[..., LiveService]) -> None:
    """`{"content": ""}` is a 422, and the OpenAPI schema states it (`minLength: 1`), so a request the
    schema calls valid is never refused (schemathesis found the mismatch)."""
    service = start_service(workers=1)
    with service.client(timeout=60) as client:
        schema = client.get("/openapi.json").json()
        content = schema["components"]["schemas"]["ExperimentCreate"]["properties"]["content"]
        assert content["minLength"] == 1, content
        response = client.post("/experiments", json={"content": ""})
        assert response.status_code == 422, response.text
        assert response.headers["content-type"] == "application/json"
        body = response.json()
        assert set(body) == {"detail", "errors"}, body
        assert body["errors"][0]["field"] == "content" and body["detail"].startswith("content: "), body
        assert client.get("/experiments", params={"limit": 5}).json()["count"] == 0  # nothing was queued
