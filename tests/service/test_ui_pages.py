"""The dashboard's pages over plain HTTP against a real service (uvicorn process, SQLite file):
status codes, the `/` redirect, security headers, escaping of stored values, filters and pages of
the jobs table, the job and registry pages' contents. The browser tests are in test_ui_browser.py."""

from __future__ import annotations

import re
from collections.abc import Callable

from service.ui.views import diagnostic_groups
from tests.utils.jobs import submit, wait_status
from tests.utils.live_service import LiveService
from tests.utils.registered import register_version

ROW = re.compile(r'<tr data-job-id="(\d+)" data-status="(\w+)">')


def _rows(html: str) -> list[tuple[int, str]]:
    return [(int(i), s) for i, s in ROW.findall(html)]


def _cells(html: str, job_id: int) -> list[str]:
    """The text of each cell of a job's row (tags stripped)."""
    row = re.search(rf'<tr data-job-id="{job_id}".*?</tr>', html, re.S)
    assert row is not None, f"no row for job {job_id}"
    cells = re.findall(r"<td[^>]*>(.*?)</td>", row.group(0), re.S)
    return [" ".join(re.sub(r"<[^>]+>", " ", c).split()) for c in cells]


def test_root_redirects_and_pages_answer_with_security_headers(
    start_service: Callable[..., LiveService],
) -> None:
    service = start_service()
    with service.client(auth=False) as client:
        root = client.get("/", follow_redirects=False)
        assert root.status_code == 307 and root.headers["location"] == "/ui"
        for path in ("/ui", "/ui/policies", "/ui/jobs/rows"):
            page = client.get(path)
            assert page.status_code == 200, path
            assert page.headers["content-type"].startswith("text/html")
            assert "script-src 'self'" in page.headers["content-security-policy"]
            assert page.headers["x-content-type-options"] == "nosniff"
            assert page.headers["server-timing"].startswith("render;dur=")
        jobs_page = client.get("/ui").text
        assets = re.findall(r'(?:src|href)="(/ui/static/[^"]+)"', jobs_page)
        assert {a.split("?")[0] for a in assets} == {
            "/ui/static/dashboard.css",
            "/ui/static/dashboard.js",
            "/ui/static/jobs.js",
            "/ui/static/submit.js",
        }
        for asset in assets:
            response = client.get(asset)
            assert response.status_code == 200 and "immutable" in response.headers["cache-control"]
        assert "http://" not in jobs_page and "https://" not in jobs_page  # nothing from outside
        missing = client.get("/ui/jobs/987654")
        assert missing.status_code == 404 and "no job with id 987654" in missing.text
        assert client.get("/ui/jobs/99999999999999999999").status_code == 422  # not a 500
        assert client.get("/ui/policies/nothing-here").status_code == 404
        # the experiments pages: shells whose script reads GET /experiments (test_ui_experiments.py)
        assert '<a href="/ui/experiments">Experiments</a>' in jobs_page
        assert client.get("/ui/experiments").status_code == 200
        assert 'id="page-data">{"experiment_id": 3}' in client.get("/ui/experiments/3").text
        assert client.get("/ui?status=exploded").status_code == 404
        assert client.get("/ui?kind=nope").status_code == 404
        assert client.get("/ui/static/../app.py").status_code == 404
        # the pages stay out of the REST API's schema (schemathesis and clients see only the API)
        assert not any(p.startswith("/ui") or p == "/" for p in client.get("/openapi.json").json()["paths"])


def test_jobs_table_newest_first_filters_and_pages(start_service: Callable[..., LiveService]) -> None:
    service = start_service(run_jobs="false")  # an API-only service: every job stays queued
    with service.client() as client:
        ids = [submit(client, "probe", episodes=5)["id"] for _ in range(53)]
        cancelled = ids[10:13]
        for job_id in cancelled:
            assert client.post(f"/jobs/{job_id}/cancel").status_code == 202
        train = submit(client, "train", algo="i2a", reward="sparse", seed=7, episodes=3)
        ids.append(train["id"])

        first = client.get("/ui").text
        assert [i for i, _ in _rows(first)] == sorted(ids, reverse=True)[:50]
        assert f"jobs 1–50 of {len(ids)}" in first and "page 1 of 2" in first
        assert 'href="/ui?page=2"' in first and 'rel="prev"' not in first
        second = client.get("/ui", params={"page": 2}).text
        assert [i for i, _ in _rows(second)] == sorted(ids, reverse=True)[50:]
        assert f"jobs 51–{len(ids)} of {len(ids)}" in second and 'href="/ui?page=1"' in second
        assert _rows(client.get("/ui", params={"page": 3}).text) == []

        only_cancelled = client.get("/ui", params={"status": "cancelled"}).text
        assert _rows(only_cancelled) == [(i, "cancelled") for i in sorted(cancelled, reverse=True)]
        assert '<option value="cancelled" selected>' in only_cancelled
        only_train = _rows(client.get("/ui", params={"kind": "train"}).text)
        assert only_train == [(train["id"], "queued")]
        nothing = client.get("/ui", params={"kind": "train", "status": "running"}).text
        assert _rows(nothing) == [] and "No jobs match this filter" in nothing
        # the live fragment answers the same rows as the page
        fragment = client.get("/ui/jobs/rows", params={"status": "cancelled"}).text
        assert "<html" not in fragment and _rows(fragment) == _rows(only_cancelled)

        config = train["resolved"]["config"]
        level = config["env"].get("level", "released")
        cells = _cells(first, train["id"])[1:]  # the first cell is the compare tick box
        assert cells[:6] == [str(train["id"]), "train", "i2a", "sparse", level, "7"]
        assert cells[6] == "queued" and cells[7] == "0 / 3"
        assert _cells(first, ids[-2])[2:7] == ["probe", "—", "—", "—", "—"]


def test_stored_values_render_as_text(start_service: Callable[..., LiveService]) -> None:
    service = start_service(run_jobs="false")
    payload = '<script>alert("x")</script><img src=x onerror=alert(1)>'
    with service.client() as client:
        register_version(service, "grasp", description=payload, tags={"note": payload})
        pairs_dir = service.folder / f"pairs-{payload}"  # a real folder: the spec is checked at submission
        pairs_dir.mkdir(parents=True)
        job = submit(client, "align", policy="grasp@1", pairs_dir=str(pairs_dir))
        tag = client.put("/policies/grasp/versions/1/tags/owner", json={"value": payload})
        assert tag.status_code == 200
        pages = {
            "job": client.get(f"/ui/jobs/{job['id']}").text,
            "policy": client.get("/ui/policies/grasp").text,
            "policies": client.get("/ui/policies").text,
        }
    escaped = "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt;&lt;img src=x onerror=alert(1)&gt;"
    for name, html in pages.items():
        assert "<script>alert" not in html and "<img src=x" not in html, name
    assert escaped in pages["job"]  # the spec's pairs_dir
    assert pages["policy"].count(escaped) >= 3  # description, two tags
    assert 'alert(\\"x\\")' not in pages["job"].split('id="page-data"')[1]  # page data carries no spec


def test_job_page_shows_config_artifacts_and_lineage(start_service: Callable[..., LiveService]) -> None:
    service = start_service()
    with service.client() as client:
        probe = submit(client, "probe", episodes=3, interval_s=0)
        wait_status(client, probe["id"], {"succeeded"})
        first = register_version(service, "grasp", source_job_id=probe["id"], tags={"algo": "i2a"})
        register_version(service, "grasp-aligned", parent=first.ref)
        assert client.put("/policies/grasp/aliases/champion", json={"version": 1}).status_code == 200
        job_page = client.get(f"/ui/jobs/{probe['id']}").text
        policy = client.get("/ui/policies/grasp").text
        aligned = client.get("/ui/policies/grasp-aligned").text
        policies = client.get("/ui/policies").text
        artifacts = client.get(f"/jobs/{probe['id']}/artifacts").json()["data"]

    for artifact in artifacts:  # every recorded file, linked to the REST download
        assert f'href="/jobs/{probe["id"]}/artifacts/{artifact["name"]}"' in job_page
    assert "summary.json" in job_page and "succeeded" in job_page
    assert 'href="/ui/policies/grasp#v1">grasp@1</a>' in job_page  # "registered as"
    assert f'<a href="/ui/jobs/{probe["id"]}">job {probe["id"]}</a>' in policy
    assert '<span class="chip alias">champion</span>' in policy
    assert 'href="/policies/grasp/versions/1/artifacts/checkpoints/best.pt"' in policy
    assert '<a href="/ui/policies/grasp#v1">grasp@1</a>' in aligned  # parent, linked
    assert "champion → v1" in policies and 'href="/ui/policies/grasp-aligned"' in policies
    grasp_row = re.search(r'<tr data-policy="grasp">.*?</tr>', policies, re.S).group(0)
    assert f'<a href="/ui/jobs/{probe["id"]}">job {probe["id"]}</a>' in grasp_row  # newest version's job
    assert '<td class="num">1</td>' in grasp_row  # one version


def test_diagnostics_panels_cover_every_key_of_the_learning_curve_picture() -> None:
    from core.dual.diagnostics_panel import PANEL_KEYS

    drawn = [key for group in diagnostic_groups() for key, _ in group["series"]]
    # the job page's extra panel: the training episodes' pair and the greedy evaluations'
    overestimation = ["charts/discounted_return", "charts/start_value", "eval/discounted_return",
                      "eval/start_value"]
    assert sorted(drawn) == sorted([*(key for key, _ in PANEL_KEYS), *overestimation])
    titles = [group["title"] for group in diagnostic_groups()]
    for wanted in ("model error", "model-based vs model-free decisions", "planning horizon", "ITM size"):
        assert wanted in titles
