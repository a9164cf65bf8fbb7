"""A job's series thinned for drawing (`job_store.metric_series`, `GET /jobs/{id}/series`): it keeps the
first and the last episode and every greedy evaluation, on SQLite and on PostgreSQL."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator

import pytest

from registry.database import Database
from service.database import job_store
from service.database.migrate import upgrade_service
from tests.utils.live_service import LiveService
from tests.utils.metric_rows import probe_like_record, record_episodes

EVALUATED = {1, 301, 600, 1201, 1777, 2999}  # a greedy evaluation at these episodes, on and off the stride


def _record(episode: int) -> dict:
    return probe_like_record(episode, evaluated=episode in EVALUATED)


def _fill(database: Database, episodes: int) -> int:
    job, _ = job_store.create_job(database, kind="probe", spec={}, resolved={}, progress_total=episodes)
    record_episodes(str(database.engine.url.render_as_string(hide_password=False)), job.id, episodes, _record)
    return job.id


@pytest.fixture()
def database(database_url: str) -> Iterator[Database]:
    db = Database(database_url)
    upgrade_service(db.engine)
    yield db
    db.dispose()


def test_downsampling_keeps_first_last_and_every_evaluation(database: Database) -> None:
    job_id = _fill(database, 3000)
    series = job_store.metric_series(database, job_id=job_id, points=100)
    episodes = [row.episode for row in series.rows]
    assert series.episodes == 3000 and series.stride == 30
    assert episodes == sorted(set(episodes))
    assert episodes[0] == 1 and episodes[-1] == 3000
    assert set(episodes) >= EVALUATED
    assert set(episodes) == set(range(30, 3001, 30)) | EVALUATED | {1, 3000}
    assert len(episodes) <= 100 + len(EVALUATED) + 2
    kept = {row.episode: row.data for row in series.rows}
    assert all(kept[e] == _record(e) for e in episodes)  # the records themselves, not averages

    whole = job_store.metric_series(database, job_id=job_id, points=3000)
    assert whole.stride == 1 and [r.episode for r in whole.rows] == list(range(1, 3001))
    empty_job, _ = job_store.create_job(database, kind="probe", spec={}, resolved={}, progress_total=None)
    nothing = job_store.metric_series(database, job_id=empty_job.id, points=100)
    assert (nothing.rows, nothing.episodes, nothing.stride) == ([], 0, 1)


def test_series_endpoint_stays_small_for_a_long_run(start_service: Callable[..., LiveService]) -> None:
    service = start_service(run_jobs="false")
    database = Database(service.settings["database_url"])
    try:
        job_id = _fill(database, 20_000)
    finally:
        database.dispose()
    with service.client() as client:
        response = client.get(f"/jobs/{job_id}/series")
        assert response.status_code == 200, response.text
        body = response.json()
        assert body["episodes"] == 20_000 and body["stride"] == 20
        episodes = [row["episode"] for row in body["data"]]
        assert episodes[0] == 1 and episodes[-1] == 20_000 and set(episodes) >= EVALUATED
        assert body["count"] == len(episodes) <= 1000 + len(EVALUATED) + 2
        assert len(response.content) < 250_000, len(response.content)  # vs ~5 MB for every record
        full = client.get(f"/jobs/{job_id}/metrics", params={"limit": 10_000})
        assert full.json()["count"] == 10_000 and len(full.content) > 5 * len(response.content)
        assert json.loads(response.content)["data"][0]["data"] == _record(1)
