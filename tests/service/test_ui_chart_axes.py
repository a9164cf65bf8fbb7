"""The dashboard's chart axes (service/ui/static/charts.js `niceRange`), run in Node where it is installed:
an axis covers its data, on multiples of its tick step, without dwarfing it. The MountainCar decisions
panel's counts (52 … 947, three ticks' room) once got the axis 499 … 501: the one tick inside the range ± 1.
The browser test (test_ui_browser.py) checks the same on real pages; this pins the arithmetic."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

CHARTS = Path(__file__).resolve().parents[2] / "service" / "ui" / "static" / "charts.js"
CASES = [
    ([52, 947], 3),  # the decisions panel: one tick (500) inside
    ([75, 983], 3),
    ([0.011, 0.044], 3),
    ([-2.6, -1.7], 5),
    ([499.5, 500.5], 3),
    ([0, 1], 4),
    ([1e-6, 3e-6], 3),
]


def _nice_ranges(cases: list[tuple[list[float], int]]) -> list[list[float]]:
    node = shutil.which("node") or shutil.which("nodejs")
    if node is None:
        pytest.skip("no Node.js here to run charts.js (the browser test covers the axes on real pages)")
    script = (
        "global.window = {dualsys: {}};"
        f"require({json.dumps(str(CHARTS))});"
        f"const cases = {json.dumps(cases)};"
        "console.log(JSON.stringify(cases.map(c => window.dualsys.charts.niceRange(c[0], c[1]))));"
    )
    result = subprocess.run([node, "-e", script], capture_output=True, text=True, timeout=60, check=True)
    return json.loads(result.stdout)


def test_an_axis_covers_its_data_on_tick_multiples_and_not_much_more() -> None:
    for (data, _count), (lo, hi) in zip(CASES, _nice_ranges(CASES), strict=True):
        assert lo <= data[0] and hi >= data[1], (data, lo, hi)
        assert (data[1] - data[0]) / (hi - lo) >= 0.4, f"{data} drawn on {lo} … {hi}: a flat line"
    assert _nice_ranges([([52, 947], 3)]) == [[0, 1000]]
