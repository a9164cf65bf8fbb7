"""Experiments and their jobs link both ways: a cell's job carries `experiment_id` and its cell (label,
reward, seed; the config's `env.id` where it has one), `GET /jobs?experiment_id=` lists an experiment's
cells, `dualsys jobs list --experiment ID` prints them, and the dashboard links job ↔ experiment.
Against a real API-only service (the cells stay queued: nothing trains)."""

from __future__ import annotations

import json
from collections.abc import Callable
from types import SimpleNamespace

import yaml
from typer.testing import CliRunner

from dualsys_cli.main import app
from service.api.presenters import job_cell
from tests.utils.experiment_files import TINY_CELL_OVERRIDES
from tests.utils.jobs import submit
from tests.utils.live_service import LiveService


def _grid() -> str:
    return yaml.safe_dump(
        {
            "name": "links",
            "rewards": ["sparse"],
            "seeds": 2,
            "steps": 40,
            "eval_every": 0,
            "overrides": TINY_CELL_OVERRIDES,
            "methods": [{"label": "DDPG", "algo": "ddpg"}, {"label": "CACLA", "algo": "cacla"}],
        },
        sort_keys=False,
    )


def test_cells_carry_their_experiment_and_filter_by_it(start_service: Callable[..., LiveService]) -> None:
    service = start_service(run_jobs="false")
    with service.client() as client:
        created = client.post("/experiments", json={"content": _grid(), "workers": 1}).json()
        other = client.post("/experiments", json={"content": _grid(), "workers": 1}).json()
        alone = submit(client, "probe", episodes=1)
        page = client.get("/jobs", params={"experiment_id": created["id"]}).json()
        assert page["count"] == 4 and len(page["data"]) == 4
        assert {j["id"] for j in page["data"]} == {c["job_id"] for c in created["jobs"]}
        cells = {(j["cell"]["label"], j["cell"]["reward"], j["cell"]["seed"]) for j in page["data"]}
        assert cells == {(m, "sparse", s) for m in ("DDPG", "CACLA") for s in (0, 1)}
        for shown in page["data"]:
            assert shown["experiment_id"] == created["id"]
            cell = shown["cell"]
            assert cell["key"] == f"{cell['label']}/{cell['reward']}/seed-{cell['seed']}"
            # carried only where the resolved config names an env id (core's `env.id`)
            assert cell["env"] == shown["resolved"]["config"]["env"].get("id")
        one = client.get(f"/jobs/{page['data'][0]['id']}").json()
        assert one["experiment_id"] == created["id"] and one["cell"] == page["data"][0]["cell"]
        assert alone["experiment_id"] is None and alone["cell"] is None
        paged = client.get("/jobs", params={"experiment_id": created["id"], "limit": 3, "status": "queued"})
        assert paged.json()["count"] == 4 and len(paged.json()["data"]) == 3
        others = client.get("/jobs", params={"experiment_id": other["id"]}).json()
        assert others["count"] == 4
        assert not {j["id"] for j in others["data"]} & {j["id"] for j in page["data"]}
        assert client.get("/jobs", params={"experiment_id": 999}).json() == {"data": [], "count": 0}
        assert client.get("/jobs", params={"experiment_id": 0}).status_code == 422

        # the dashboard: a cell's job page links to its experiment and its sibling cells; the experiment
        # page links to its cells in the jobs table, which the jobs page filters
        job_page = client.get(f"/ui/jobs/{one['id']}").text
        assert f'href="/ui/experiments/{created["id"]}"' in job_page
        assert f'href="/ui?experiment_id={created["id"]}"' in job_page
        experiment_page = client.get(f"/ui/experiments/{created['id']}").text
        assert f'href="/ui?experiment_id={created["id"]}"' in experiment_page
        table = client.get("/ui", params={"experiment_id": created["id"]}).text
        shown_ids = {int(part.split('"')[0]) for part in table.split('data-job-id="')[1:]}
        assert shown_ids == {j["id"] for j in page["data"]}
        rows = client.get("/ui/jobs/rows", params={"experiment_id": other["id"]}).text
        assert {int(part.split('"')[0]) for part in rows.split('data-job-id="')[1:]} == {
            j["id"] for j in others["data"]
        }

    env = {"DUALSYS_URL": service.url, "DUALSYS_TOKEN": service.token or ""}
    result = CliRunner().invoke(app, ["jobs", "list", "--experiment", str(created["id"]), "--json"], env=env)
    assert result.exit_code == 0, result.output
    assert {j["id"] for j in json.loads(result.output)["data"]} == {j["id"] for j in page["data"]}
    wide = {**env, "COLUMNS": "200"}  # rich fits the table to the terminal
    result = CliRunner().invoke(app, ["jobs", "list", "--experiment", str(created["id"])], env=wide)
    assert result.exit_code == 0 and "4 job(s) of experiment" in result.output
    assert "DDPG/sparse/seed-1" in result.output and "CACLA/sparse/seed-0" in result.output


def test_a_cell_carries_the_env_id_of_its_config() -> None:
    row = SimpleNamespace(
        experiment_id=3,
        cell="SAC/dense/seed-2",
        resolved={
            "config": {"env": {"id": "Pendulum-v1", "reward_mode": "dense"}},
            "cell": {"label": "SAC", "reward": "dense", "seed": 2},
        },
    )
    cell = job_cell(row)
    assert cell is not None and cell.model_dump() == {
        "key": "SAC/dense/seed-2",
        "label": "SAC",
        "reward": "dense",
        "seed": 2,
        "env": "Pendulum-v1",
    }
    assert job_cell(SimpleNamespace(experiment_id=None, cell=None, resolved={})) is None
