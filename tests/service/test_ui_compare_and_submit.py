"""The dashboard's comparison, submission and long-run pages in headless Chromium against a real service:
jobs ticked in the table are overlaid on one chart (one curve each, smoothing on a slider); an
experiment's page draws each method's mean ± band; a training job and an experiment file are submitted
from the pages, a bad field shows the API's own message beside it and a good job appears in the table;
a long run's page loads a thinned series and every episode on demand. Assertions on the DOM;
screenshots in the test's tmp folder."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.utils.browser import console_errors
from tests.utils.experiment_files import TINY_CELL_OVERRIDES
from tests.utils.jobs import submit, wait_status
from tests.utils.live_service import LiveService, wait_for
from tests.utils.metric_rows import probe_like_record, record_episodes

pytestmark = pytest.mark.timeout(420)
REFUSED = ("status of 422", "status of 401")  # a refused REST call is logged as a failed load


@pytest.fixture()
def shot(browser: Any, tmp_path: Path) -> Iterator[Callable[[str], None]]:
    browser.get("about:blank")
    console_errors(browser)
    yield lambda name: browser.save_screenshot(str(tmp_path / f"{name}.png"))
    browser.get("about:blank")


def _js(browser: Any, script: str, *args: Any) -> Any:
    return browser.execute_script(script, *args)


def _curve_keys(browser: Any, figure: str, kind: str = "line") -> list[str]:
    script = (
        "return Array.from(document.querySelectorAll(arguments[0] + ' path.' + arguments[1]))"
        ".map(function (p) { return p.dataset.key; });"
    )
    return _js(browser, script, figure, kind)


def _set_token(browser: Any, token: str) -> None:
    field = browser.find_element("id", "token")
    field.clear()
    field.send_keys(token)


def _grid(name: str, seeds: int) -> str:
    return yaml.safe_dump(
        {
            "name": name,
            "rewards": ["sparse"],
            "seeds": seeds,
            "steps": 40,
            "eval_every": 0,
            "overrides": TINY_CELL_OVERRIDES,
            "methods": [{"label": "DDPG", "algo": "ddpg"}, {"label": "CACLA", "algo": "cacla"}],
        },
        sort_keys=False,
    )


def test_compare_overlays_one_curve_per_chosen_job(
    browser: Any, shot: Callable[[str], None], start_service: Callable[..., LiveService]
) -> None:
    service = start_service(workers=1)
    with service.client() as client:
        jobs = [submit(client, "probe", episodes=30, interval_s=0) for _ in range(4)]
        for created in jobs:
            wait_status(client, created["id"], {"succeeded"}, timeout=120)
    chosen = [str(j["id"]) for j in jobs[:3]]
    browser.get(f"{service.url}/ui")
    for job_id in chosen:
        browser.find_element("css selector", f'tr[data-job-id="{job_id}"] input.pick').click()
    button = browser.find_element("id", "compare-button")
    assert button.text == "Compare 3 chosen jobs"
    # the table refreshes its rows once a second: the ticks survive it
    before = _js(browser, "return document.getElementById('jobs-body').innerHTML.length")
    wait_for(lambda: browser.find_element("id", "live-state").text == "live", timeout=20, what="a refresh")
    ticked = _js(
        browser, "return Array.from(document.querySelectorAll('input.pick:checked')).map(b => b.value)"
    )
    assert sorted(ticked) == sorted(chosen) and before
    button.click()
    wait_for(lambda: "/ui/compare" in browser.current_url, timeout=20, what="the compare page")
    wait_for(
        lambda: _js(browser, "return document.getElementById('compare-return').dataset.curves") == "3",
        timeout=30,
        what="three curves",
    )
    assert sorted(_curve_keys(browser, "#compare-return")) == sorted(chosen)
    assert sorted(_curve_keys(browser, "#compare-success")) == sorted(chosen)
    first = _js(browser, "return document.querySelector('#compare-return path.line').getAttribute('d')")
    _js(
        browser,
        "const s = document.getElementById('smoothing'); s.value = 1; s.dispatchEvent(new Event('input'))",
    )
    assert "1 points" in browser.find_element("id", "smoothing-text").text
    again = _js(browser, "return document.querySelector('#compare-return path.line').getAttribute('d')")
    assert again != first  # unsmoothed: a different curve, still three of them
    assert len(_curve_keys(browser, "#compare-return")) == 3
    shot("compare")
    assert console_errors(browser) == []


def test_experiment_page_draws_each_methods_mean_and_band(
    browser: Any, shot: Callable[[str], None], start_service: Callable[..., LiveService]
) -> None:
    service = start_service(run_jobs="false")  # API-only: the cells' histories are written below
    with service.client() as client:
        created = client.post("/experiments", json={"content": _grid("curves", seeds=3), "workers": 1}).json()
    for index, cell in enumerate(created["jobs"]):
        offset = 1.0 if cell["cell"].startswith("CACLA") else 0.0
        record_episodes(
            service.settings["database_url"],
            cell["job_id"],
            400 + 50 * index,
            lambda e, o=offset + 0.1 * index: probe_like_record(e, offset=o),
        )
    browser.get(f"{service.url}/ui/experiments/{created['id']}")
    wait_for(
        lambda: (
            _js(browser, "const f = document.querySelector('#curves figure'); return f && f.dataset.methods")
            == "2"
        ),
        timeout=30,
        what="the curves of two methods",
    )
    assert sorted(_curve_keys(browser, "#curves", "line")) == ["CACLA", "DDPG"]
    assert sorted(_curve_keys(browser, "#curves", "band")) == ["CACLA", "DDPG"]
    legend = _js(
        browser,
        "return Array.from(document.querySelectorAll('#curves .legend-text')).map(t => t.textContent)",
    )
    assert sorted(legend) == ["CACLA (3 seeds)", "DDPG (3 seeds)"]
    shot("experiment-curves")
    # cells ticked in the grid open the compare page with their jobs
    cells = [c["job_id"] for c in created["jobs"][:2]]
    for job_id in cells:
        browser.find_element("css selector", f'#grid td[data-job-id="{job_id}"] input.pick').click()
    browser.find_element("id", "compare-cells").click()
    wait_for(
        lambda: (
            "/ui/compare" in browser.current_url
            and _js(browser, "return document.getElementById('compare-return').dataset.curves") == "2"
        ),
        timeout=30,
        what="two cells compared",
    )
    assert sorted(_curve_keys(browser, "#compare-return")) == sorted(str(c) for c in cells)
    assert console_errors(browser) == []


def test_submit_a_training_job_from_the_jobs_page(
    browser: Any, shot: Callable[[str], None], start_service: Callable[..., LiveService]
) -> None:
    service = start_service(run_jobs="false")  # the submitted job stays queued
    browser.get(f"{service.url}/ui")
    _set_token(browser, service.token or "")
    browser.find_element("css selector", "#submit-train-box summary").click()
    form = browser.find_element("id", "submit-train")
    form.find_element("name", "episodes").send_keys("0")
    form.find_element("css selector", "button[type=submit]").click()
    error = 'span.field-error[data-error-for="spec.episodes"]'
    wait_for(
        lambda: _js(browser, f"return !!document.querySelector('{error}')"), timeout=20, what="the error"
    )
    message = browser.find_element("css selector", error).text
    assert message == "Input should be greater than or equal to 1"  # the API's own words, beside the field
    assert "HTTP 422: spec.episodes" in form.find_element("css selector", "[data-result]").text
    shot("submit-refused")

    overrides = form.find_element("name", "overrides")
    overrides.send_keys('{"agent.batch_size": "many"}')
    episodes = form.find_element("name", "episodes")
    episodes.clear()
    episodes.send_keys("5")
    form.find_element("css selector", "button[type=submit]").click()
    error = 'span.field-error[data-error-for="spec.overrides"]'
    wait_for(
        lambda: _js(browser, f"return !!document.querySelector('{error}')"), timeout=20, what="the error"
    )
    assert "agent.batch_size" in browser.find_element("css selector", error).text

    overrides.clear()
    overrides.send_keys('{"agent.batch_size": 16}')
    form.find_element("css selector", "select[name=algo] option[value=ddpg]").click()
    form.find_element("css selector", "button[type=submit]").click()
    link = "[data-result] a[data-job-id]"
    wait_for(lambda: _js(browser, f"return !!document.querySelector('{link}')"), timeout=20, what="the job")
    job_id = browser.find_element("css selector", link).get_attribute("data-job-id")
    assert not _js(browser, "return document.querySelector('span.field-error')")
    wait_for(
        lambda: _js(browser, f"return !!document.querySelector('tr[data-job-id=\"{job_id}\"]')"),
        timeout=20,
        what="the job in the table",
    )
    with service.client() as client:
        shown = client.get(f"/jobs/{job_id}").json()
    assert shown["spec"]["episodes"] == 5 and shown["spec"]["overrides"] == {"agent.batch_size": 16}
    assert shown["resolved"]["config"]["run"]["algo"] == "ddpg"
    shot("submitted")
    assert console_errors(browser, allow=REFUSED) == []


def test_submit_an_experiment_file_from_the_experiments_page(
    browser: Any, shot: Callable[[str], None], start_service: Callable[..., LiveService]
) -> None:
    service = start_service(run_jobs="false")
    browser.get(f"{service.url}/ui/experiments")
    _set_token(browser, service.token or "")
    browser.find_element("css selector", "#submit-experiment-box summary").click()
    form = browser.find_element("id", "submit-experiment")
    content = form.find_element("name", "content")
    bad = _grid("bad-seeds", seeds=2).replace("seeds: 2", "seeds: 0")
    _js(browser, "arguments[0].value = arguments[1]", content, bad)
    form.find_element("css selector", "button[type=submit]").click()
    error = 'span.field-error[data-error-for="content"]'
    wait_for(
        lambda: _js(browser, f"return !!document.querySelector('{error}')"), timeout=20, what="the error"
    )
    assert "seeds" in browser.find_element("css selector", error).text
    shot("experiment-refused")

    _js(browser, "arguments[0].value = arguments[1]", content, _grid("from-the-page", seeds=1))
    form.find_element("css selector", "button[type=submit]").click()
    link = "[data-result] a[data-experiment-id]"
    wait_for(lambda: _js(browser, f"return !!document.querySelector('{link}')"), timeout=20, what="it")
    experiment_id = browser.find_element("css selector", link).get_attribute("data-experiment-id")
    assert "2 cells queued" in form.find_element("css selector", "[data-result]").text
    wait_for(
        lambda: _js(
            browser, f"return !!document.querySelector('tr[data-experiment-id=\"{experiment_id}\"]')"
        ),
        timeout=20,
        what="the experiment in the list",
    )
    shot("experiment-submitted")
    assert console_errors(browser, allow=REFUSED) == []


def test_a_long_runs_page_loads_a_thinned_series_and_every_episode_on_demand(
    browser: Any, shot: Callable[[str], None], start_service: Callable[..., LiveService]
) -> None:
    service = start_service(run_jobs="false")
    with service.client() as client:
        created = submit(client, "probe", episodes=6000)
        client.post(f"/jobs/{created['id']}/cancel")
    record_episodes(
        service.settings["database_url"],
        created["id"],
        6000,
        lambda e: probe_like_record(e, evaluated=e % 1000 == 1),
    )
    browser.get(f"{service.url}/ui/jobs/{created['id']}")
    curve = "#curve"
    wait_for(
        lambda: _js(browser, f"return document.querySelector('{curve}').dataset.stride") == "6", timeout=30
    )
    points = int(_js(browser, f"return document.querySelector('{curve}').dataset.points"))
    assert 1000 <= points <= 1000 + 6 + 2
    assert "of 6000 episodes" in browser.find_element("id", "curve-count").text
    assert "6 greedy evaluations" in browser.find_element("id", "curve-count").text
    shot("thinned")
    browser.find_element("id", "full-resolution").click()
    wait_for(
        lambda: _js(browser, f"return document.querySelector('{curve}').dataset.points") == "6000",
        timeout=60,
        what="every episode",
    )
    assert not browser.find_element("id", "full-resolution").is_displayed()
    assert console_errors(browser) == []
