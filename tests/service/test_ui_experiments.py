"""The dashboard's experiments pages in headless Chromium against a real service: the grid of an
experiment's cells (method × reward × seed) with their states and links to their jobs, cancel refused
without the token and done with it; and, with real (tiny) cells run to the end, the report's table and
figure. Assertions on the DOM; screenshots in the test's tmp folder."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.utils.browser import console_errors
from tests.utils.experiment_files import TINY_CELL_OVERRIDES
from tests.utils.live_service import LiveService, wait_for

REFUSED = ("status of 401",)
TINY = {**TINY_CELL_OVERRIDES, "env.max_steps": 10}


def _experiment(name: str, *, rewards: list[str], seeds: int, steps: int, description: str = "") -> str:
    return yaml.safe_dump(
        {
            "name": name,
            "description": description,
            "rewards": rewards,
            "seeds": seeds,
            "steps": steps,
            "eval_every": 0,
            "eval_episodes": 1,
            "overrides": TINY,
            "baseline": "DDPG",
            "methods": [{"label": "DDPG", "algo": "ddpg"}, {"label": "CACLA", "algo": "cacla"}],
        },
        sort_keys=False,
    )


@pytest.fixture()
def shot(browser: Any, tmp_path: Path) -> Iterator[Callable[[str], None]]:
    browser.get("about:blank")
    console_errors(browser)
    yield lambda name: browser.save_screenshot(str(tmp_path / f"{name}.png"))
    browser.get("about:blank")


def _cells(browser: Any) -> list[tuple[str, str, str]]:
    """(method, status, job link) of every grid cell, read in one script."""
    script = """
        return Array.from(document.querySelectorAll('#grid tbody tr')).flatMap(function (tr) {
          const method = tr.querySelector('th').textContent;
          return Array.from(tr.querySelectorAll('td.cell')).map(function (td) {
            const a = td.querySelector('a');
            return [method, td.dataset.status || '', a ? a.getAttribute('href') : ''];
          });
        });"""
    return [tuple(cell) for cell in browser.execute_script(script)]


@pytest.mark.timeout(420)
def test_experiment_grid_states_and_cancel_needs_the_token(
    browser: Any, shot: Callable[[str], None], start_service: Callable[..., LiveService]
) -> None:
    service = start_service(run_jobs="false")  # API-only: the cells stay queued until cancelled
    content = _experiment(
        "grid-check",
        rewards=["dense", "sparse"],
        seeds=2,
        steps=40,
        description="<b>bold</b><script>x=1</script>",
    )
    with service.client(timeout=180) as client:
        response = client.post("/experiments", json={"content": content, "workers": 1})
        assert response.status_code == 202, response.text
        created = response.json()
    browser.get(f"{service.url}/ui")
    browser.find_element("link text", "Experiments").click()
    wait_for(
        lambda: browser.find_elements("css selector", f'tr[data-experiment-id="{created["id"]}"]'),
        timeout=30,
        what="the experiments list",
    )
    row = browser.find_element("css selector", f'tr[data-experiment-id="{created["id"]}"]')
    assert "grid-check" in row.text
    shot("experiments")
    row.find_element("css selector", "td:nth-child(2) a").click()
    wait_for(lambda: len(_cells(browser)) == 8, timeout=30, what="the grid's 8 cells")
    cells = _cells(browser)
    assert sorted({m for m, _, _ in cells}) == ["CACLA", "DDPG"]
    assert {s for _, s, _ in cells} == {"queued"}
    assert sorted(href for _, _, href in cells) == sorted(f"/ui/jobs/{j['job_id']}" for j in created["jobs"])
    headers = [e.text for e in browser.find_elements("css selector", "#grid thead th")]
    assert "dense reward" in headers and "sparse reward" in headers and headers.count("seed 0") == 2
    assert "0 of 8 cells done" in browser.find_element("id", "experiment-cells").text
    assert "appears once a cell has finished" in browser.find_element("id", "report").text
    spec = browser.find_element("id", "experiment-spec").get_attribute("textContent")
    assert "<b>bold</b><script>x=1</script>" in spec  # the file's description, as text
    assert browser.find_elements("css selector", "main b, main script") == []

    browser.find_element("id", "cancel-button").click()
    wait_for(
        lambda: "HTTP 401" in browser.find_element("id", "cancel-result").text, timeout=20, what="refusal"
    )
    assert "missing or invalid bearer token" in browser.find_element("id", "cancel-result").text
    shot("experiment-refused")
    with service.client() as client:
        assert (
            client.get(f"/experiments/{created['id']}", params={"report": "false"}).json()["status"]
            == "queued"
        )
    browser.find_element("id", "token").send_keys(service.token)
    browser.find_element("id", "cancel-button").click()
    wait_for(lambda: {s for _, s, _ in _cells(browser)} == {"cancelled"}, timeout=30, what="cancelled cells")
    assert browser.find_element("css selector", "#experiment-status .status").text == "cancelled"
    assert not browser.find_element("id", "cancel-box").is_displayed()
    shot("experiment-cancelled")
    assert console_errors(browser, allow=REFUSED) == []


@pytest.mark.timeout(1800)  # each cell process imports torch and PyBullet: minutes on a loaded machine
def test_experiment_report_table_and_figure_from_real_cells(
    browser: Any, shot: Callable[[str], None], start_service: Callable[..., LiveService]
) -> None:
    service = start_service(workers=2)
    content = _experiment("tiny", rewards=["sparse"], seeds=1, steps=20)
    with service.client(timeout=180) as client:
        created = client.post("/experiments", json={"content": content, "workers": 2}).json()
        browser.get(f"{service.url}/ui/experiments/{created['id']}")

        def finished() -> dict | None:
            current = client.get(f"/experiments/{created['id']}", params={"report": "false"}).json()
            return current if current["cells"]["queued"] == 0 and current["cells"]["running"] == 0 else None

        done = wait_for(finished, timeout=1500, interval=1.0, what="the experiment to finish")
        assert done["cells"]["done"] == 2, done
        # The service bootstraps a report once per set of finished cells (slow on a loaded machine) and
        # answers with the latest finished one, flagged report_pending while a newer one is computed: a
        # report of the first finished cell alone can come first. Wait for the report of both, then for
        # the page, which asks again while its report is pending, to show it.

        def current_report() -> dict | None:
            body = client.get(f"/experiments/{created['id']}").json()
            report = body["report"]
            current = report is not None and report["done"] == 2 and not body["report_pending"]
            return report if current else None

        report = wait_for(current_report, timeout=600, interval=1.0, what="the report of both cells")
        wait_for(
            lambda: browser.execute_script(  # one read of the table, which a redraw cannot leave stale
                "return Array.from(document.querySelectorAll('#report table.report tbody tr'),"
                " row => row.querySelector('td').textContent.trim())"
            ) == ["1", "1"],
            timeout=120,
            what="the page's report of both cells",
        )
    rows = {
        r.find_element("css selector", "th").text: [c.text for c in r.find_elements("css selector", "td")]
        for r in browser.find_elements("css selector", "#report table.report tbody tr")
    }
    assert set(rows) == {"DDPG", "CACLA"}
    for label, cells in rows.items():
        entry = report["methods"][label]["sparse"]
        assert cells[0] == str(entry["seeds"]) == "1"
        for column, metric in ((4, "train_success"), (5, "success")):  # IQMs, as the page's JS prints them
            iqm = entry[metric]["iqm"]
            assert cells[column].startswith("—" if iqm is None else f"{iqm:#.3g}"), (metric, cells)
    assert rows["CACLA"][-1].endswith("vs DDPG")  # probability of improvement over the baseline
    assert {s for _, s, _ in _cells(browser)} == {"succeeded"}
    assert len(browser.find_elements("css selector", "#report svg.scores circle.iqm")) <= 4
    assert browser.find_elements("css selector", "#report svg.scores")
    shot("experiment-report")
    assert console_errors(browser) == []
