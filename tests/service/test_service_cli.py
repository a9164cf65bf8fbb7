"""`dualsys jobs ...`, `dualsys registry ...` and `dualsys serve` as a user runs them."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from dualsys_cli.main import app
from tests.utils.live_service import LiveService
from tests.utils.run_dirs import make_run_dir


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveService]:
    live = LiveService(tmp_path_factory.mktemp("cli")).start()
    yield live
    live.kill()


def _run(args: list[str], env: dict[str, str]) -> tuple[int, str]:
    result = CliRunner().invoke(app, args, env=env)
    return result.exit_code, result.output


def test_jobs_submit_watch_show_list_cancel(service: LiveService) -> None:
    env = {"DUALSYS_URL": service.url, "DUALSYS_TOKEN": service.token or ""}
    code, out = _run(["jobs", "submit", "probe", "--episodes", "3", "--interval", "0.05", "--json"], env)
    assert code == 0, out
    submitted = json.loads(out)
    assert set(submitted) == {"id", "status"} and submitted["status"] == "queued"
    job_id = str(submitted["id"])
    code, out = _run(["jobs", "watch", job_id], env)
    assert code == 0 and out.strip().endswith(f"job {job_id} succeeded"), out
    code, out = _run(["jobs", "show", job_id, "--json"], env)
    shown = json.loads(out)
    assert code == 0 and shown["status"] == "succeeded" and shown["progress"] == {"episode": 3, "total": 3}
    code, out = _run(["jobs", "list", "--json", "--status", "succeeded"], env)
    assert code == 0 and json.loads(out)["count"] >= 1
    code, out = _run(["jobs", "cancel", job_id], env)
    assert (
        code == 2
        and out.strip()
        == f"error: job {job_id} already succeeded; only queued or running jobs can be cancelled (HTTP 409)"
    )


def test_jobs_user_errors_are_one_line_with_exit_2(service: LiveService) -> None:
    env = {"DUALSYS_URL": service.url, "DUALSYS_TOKEN": service.token or ""}
    code, out = _run(["jobs", "submit", "train", "--set", "agent.nope=1"], env)
    assert (
        code == 2
        and out.startswith("error: spec.overrides: unknown config key 'agent.nope'")
        and out.count("\n") == 1
    )
    code, out = _run(["jobs", "submit", "probe"], {"DUALSYS_URL": service.url, "DUALSYS_TOKEN": ""})
    assert code == 2 and "bearer token" in out and "(HTTP 401)" in out
    code, out = _run(["jobs", "show", "424242", "--url", service.url], env)
    assert code == 2 and out.strip() == "error: no job with id 424242 (HTTP 404)"
    code, out = _run(["jobs", "list", "--url", "http://127.0.0.1:9"], env)
    assert code == 2 and out.startswith("error: cannot reach the dualsys service at http://127.0.0.1:9")


def test_registry_cli_register_alias_list_show(tmp_path: Path) -> None:
    env = {
        "DUALSYS_DATABASE_URL": f"sqlite:///{tmp_path / 'r.db'}",
        "DUALSYS_ARTIFACTS": str(tmp_path / "store"),
    }
    run = make_run_dir(tmp_path / "run", seed=5)
    code, out = _run(["registry", "register", "grasp", str(run), "--tag", "algo=i2a"], env)
    assert code == 0 and out.strip() == "registered grasp@1", out
    code, out = _run(["registry", "register", "grasp-real", str(run), "--parent", "grasp@1", "--json"], env)
    assert code == 0 and json.loads(out)["parent"] == "grasp@1"
    code, out = _run(["registry", "alias", "grasp", "champion", "1"], env)
    assert code == 0 and out.strip() == "grasp@champion → grasp@1"
    code, out = _run(["registry", "list", "--json"], env)
    listing = {p["name"]: p for p in json.loads(out)}
    assert listing["grasp"]["aliases"] == {"champion": 1} and listing["grasp-real"]["latest_version"] == 1
    code, out = _run(["registry", "show", "grasp@champion", "--json"], env)
    shown = json.loads(out)
    assert (
        code == 0
        and shown["version"] == 1
        and shown["tags"] == {"algo": "i2a"}
        and shown["config"]["seed"] == 5
    )
    code, out = _run(["registry", "show", "nope@1"], env)
    assert code == 2 and out.strip() == "error: no registered policy named 'nope'"
    code, out = _run(["registry", "register", "grasp", str(tmp_path / "missing")], env)
    assert code == 2 and "does not exist" in out
    code, out = _run(["registry", "alias", "grasp", "latest", "1"], env)
    assert code == 2 and "reserved" in out


def test_registry_register_from_a_service_job(service: LiveService, tmp_path: Path) -> None:
    env = {
        "DUALSYS_DATABASE_URL": service.settings["database_url"],
        "DUALSYS_ARTIFACTS": service.settings["artifacts"],
    }
    with service.client() as client:
        job = client.post("/jobs", json={"kind": "probe", "spec": {"episodes": 1, "interval_s": 0}}).json()
    code, out = _run(["registry", "register", "x", "--job", str(job["id"])], env)
    # a probe job has no policy checkpoint: the registry says so in one line
    assert code == 2 and ("holds no checkpoint" in out or "only a succeeded job" in out), out


def test_serve_refuses_a_public_address_without_a_token() -> None:
    code, out = _run(["serve", "--host", "0.0.0.0", "--port", "1"], {"DUALSYS_TOKEN": ""})
    assert code == 2 and out.strip().startswith("error: refusing to bind 0.0.0.0")
    code, out = _run(["serve", "--executor", "spark"], {})
    assert code == 2 and "unknown executor" in out


def test_registry_reads_never_create_a_database(tmp_path: Path) -> None:
    missing = tmp_path / "none.db"
    code, out = _run(["registry", "list", "--db", str(missing)], {})
    assert code == 2 and out.strip().startswith(f"error: no policy registry at {missing}")
    assert not missing.exists()
