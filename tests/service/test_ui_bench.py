"""Smoke test of `bench.dashboard_speed`: it fills a real database, starts a real service, and its
figures hold what the docs quote (a full page of 50 rows, timings, first-load bytes by part)."""

from __future__ import annotations

from bench.dashboard_speed import measure


def test_dashboard_bench_reports_render_time_and_first_load_weight() -> None:
    result = measure(loads=2)
    assert result["jobs"] == 1000 and result["rows_on_page"] == 50
    assert result["jobs_page_render_ms_p50"] > 0 and result["jobs_page_http_ms_p50"] > 0
    parts = result["jobs_page_first_load_parts"]
    assert set(parts) == {
        "/ui",
        "/ui/static/dashboard.css",
        "/ui/static/dashboard.js",
        "/ui/static/jobs.js",
        "/ui/static/submit.js",
        "/ui/jobs/rows?page=1",
    }
    assert result["jobs_page_first_load_bytes"] == sum(parts.values())
    assert result["job_page_first_load_bytes"] > result["job_page_metric_rows"] * 100  # the metrics came
    # a 100 000-episode run's page draws a thinned series: a fraction of its records' weight
    assert result["long_run_page_first_load_bytes"] < result["long_run_every_episode_bytes"] / 20
