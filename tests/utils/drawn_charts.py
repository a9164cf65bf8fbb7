"""What the dashboard's SVG charts (service/ui/static/charts.js) actually draw, read back from the browser's
DOM and turned into values, and checked against a run's metrics.csv.

A chart carries its plot frame (`data-frame`: left top width height) and its axes' ranges (`data-x`,
`data-left`, `data-right`); each drawn line (`path.line`) and dot group (`g.dots`) carries its metric key
(`data-key`) and its axis (`data-axis`). Inverting the pixel coordinates with them gives the values drawn,
which `check_drawn_against_metrics` compares with what metrics.csv holds: the same points, inside the frame,
spread over the axis (not a flat line or a stroke off the chart), and legends a person reads.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass
from typing import Any

READ_CHARTS = """
return Array.from(document.querySelectorAll(arguments[0])).map(function (svg) {
  const figure = svg.closest('figure');
  return {
    panel: figure ? (figure.id || figure.dataset.keys || '') : '',
    window: Number((svg.closest('[data-window]') || {dataset: {window: '1'}}).dataset.window),
    title: (svg.querySelector('title') || {}).textContent || '',
    frame: svg.dataset.frame || '', x: svg.dataset.x || '',
    left: svg.dataset.left || '', right: svg.dataset.right || '',
    legend: Array.from(svg.querySelectorAll('.legend-text'), function (e) { return e.textContent; }),
    lines: Array.from(svg.querySelectorAll('path.line'), function (p) {
      return {key: p.dataset.key || '', axis: p.dataset.axis || '', cls: p.getAttribute('class'),
              d: p.getAttribute('d')};
    }),
    dots: Array.from(svg.querySelectorAll('g.dots'), function (g) {
      return {key: g.dataset.key || '', axis: g.dataset.axis || '', cls: g.getAttribute('class'),
              points: Array.from(g.querySelectorAll('circle'), function (c) {
                return [Number(c.getAttribute('cx')), Number(c.getAttribute('cy'))]; })};
    }),
  };
});
"""
"""One script run reads every chart (the page may redraw between a find and a read)."""

PATH_POINT = re.compile(r"([ML])(-?[\d.]+) (-?[\d.]+)")
"""One point of an SVG path as charts.js writes it (`M52.0 32.7L170.0 84.4`)."""
METRIC_KEY = re.compile(r"[a-z_]+/[a-z_0-9]+")
"""What a metrics.csv column looks like (`dual/mb_decisions`); a legend must not be one."""


@dataclass
class DrawnSeries:
    key: str
    kind: str  # "line" or "dots"
    cls: str
    axis: str
    points: list[tuple[float, float]]  # (x, y) in data units
    pixels: list[tuple[float, float]]


@dataclass
class DrawnChart:
    panel: str
    title: str
    window: int
    frame: tuple[float, float, float, float]
    ranges: dict[str, tuple[float, float]]
    legend: list[str]
    series: list[DrawnSeries]


def read_charts(browser: Any, selector: str) -> list[DrawnChart]:
    """Every chart under `selector` (e.g. `#diagnostics svg.plot`), its drawn points as values."""
    charts = []
    for raw in browser.execute_script(READ_CHARTS, selector):
        left, top, width, height = (float(v) for v in raw["frame"].split())
        ranges = {
            side: (float(raw[side].split()[0]), float(raw[side].split()[1]))
            for side in ("x", "left", "right")
            if raw[side]
        }
        chart = DrawnChart(
            panel=raw["panel"],
            title=raw["title"],
            window=int(raw["window"] or 1),
            frame=(left, top, width, height),
            ranges=ranges,
            legend=list(raw["legend"]),
            series=[],
        )
        for line in raw["lines"]:
            pixels = [(float(x), float(y)) for _, x, y in PATH_POINT.findall(line["d"])]
            chart.series.append(
                DrawnSeries(
                    line["key"],
                    "line",
                    line["cls"],
                    line["axis"],
                    _values(chart, pixels, line["axis"]),
                    pixels,
                )
            )
        for dots in raw["dots"]:
            pixels = [(float(x), float(y)) for x, y in dots["points"]]
            chart.series.append(
                DrawnSeries(
                    dots["key"],
                    "dots",
                    dots["cls"],
                    dots["axis"],
                    _values(chart, pixels, dots["axis"]),
                    pixels,
                )
            )
        charts.append(chart)
    return charts


def _values(chart: DrawnChart, pixels: list[tuple[float, float]], axis: str) -> list[tuple[float, float]]:
    """Pixel coordinates back to data values, with the chart's frame and axis ranges."""
    left, top, width, height = chart.frame
    x0, x1 = chart.ranges["x"]
    y0, y1 = chart.ranges[axis]
    return [
        (x0 + (px - left) / width * (x1 - x0), y0 + (top + height - py) / height * (y1 - y0))
        for px, py in pixels
    ]


def metrics_columns(text: str) -> dict[str, list[float]]:
    """metrics.csv as columns of floats (NaN where a record has no value)."""
    rows = list(csv.DictReader(io.StringIO(text)))
    assert rows, "metrics.csv holds no records"

    def number(raw: str | None) -> float:
        try:
            return float(raw) if raw not in (None, "") else math.nan
        except ValueError:
            return math.nan

    return {key: [number(row.get(key)) for row in rows] for key in rows[0]}


def trailing_mean(values: list[float], window: int) -> list[float]:
    """charts.js's `smooth`: the mean of the last `window` finite values so far (NaN before the first)."""
    out, recent = [], []
    for value in values:
        if math.isfinite(value):
            recent = [*recent, value][-window:]
        out.append(sum(recent) / len(recent) if recent else math.nan)
    return out


def expected_points(
    columns: dict[str, list[float]], series: DrawnSeries, window: int, *, raw: bool = False
) -> list[tuple[float, float]]:
    """The (env step, value) points metrics.csv says `series` should draw: dots, and the line under them or
    the learning curve's raw line (`raw`), at each record with a value; a smoothed line from the first value
    on."""
    xs = columns["global_step"]
    ys = columns[series.key]
    if series.kind == "line" and not raw and "raw" not in series.cls.split():
        ys = trailing_mean(ys, window)
    return [(x, y) for x, y in zip(xs, ys, strict=True) if math.isfinite(y)]


def check_drawn_against_metrics(chart: DrawnChart, columns: dict[str, list[float]]) -> list[str]:
    """What `chart` draws that metrics.csv does not say (empty when it draws the run's values)."""
    problems = []
    left, top, width, height = chart.frame
    name = chart.panel or chart.title
    for text in chart.legend:
        if METRIC_KEY.fullmatch(text.strip()):
            problems.append(f"{name}: legend shows the raw key {text!r}")
    spans: dict[str, list[float]] = {}
    dotted = {series.key for series in chart.series if series.kind == "dots"}  # their lines are not smoothed
    for series in chart.series:
        if series.key not in columns:
            problems.append(f"{name}: draws {series.key!r}, which metrics.csv has no column for")
            continue
        wanted = expected_points(columns, series, chart.window, raw=series.key in dotted)
        if series.kind == "dots":
            wanted = wanted[:400]  # charts.js draws at most 400 dots a series
        label = f"{name}: {series.key} ({series.kind})"
        if len(series.points) != len(wanted):
            problems.append(f"{label}: {len(series.points)} points drawn, metrics.csv has {len(wanted)}")
            continue
        outside = [
            p
            for p in series.pixels
            if not (left - 0.6 <= p[0] <= left + width + 0.6 and top - 0.6 <= p[1] <= top + height + 0.6)
        ]
        if outside:
            problems.append(f"{label}: {len(outside)} points drawn outside the plot, e.g. {outside[0]}")
        x0, x1 = chart.ranges["x"]
        y0, y1 = chart.ranges[series.axis]
        x_tolerance = (x1 - x0) / width * 0.6 + 1e-9
        y_tolerance = (y1 - y0) / height * 0.6 + 1e-9
        for (x, y), (want_x, want_y) in zip(series.points, wanted, strict=True):
            if abs(x - want_x) > x_tolerance or abs(y - want_y) > y_tolerance:
                problems.append(
                    f"{label}: drew ({x:.6g}, {y:.6g}) where metrics.csv has ({want_x:.6g}, {want_y:.6g})"
                )
                break
        if series.axis == "left":
            spans.setdefault("left", []).extend(y for _, y in wanted)
    values = spans.get("left", [])
    if values and max(values) > min(values):
        y0, y1 = chart.ranges["left"]
        share = (max(values) - min(values)) / (y1 - y0)
        if share < 0.3:
            problems.append(
                f"{name}: its values span {share:.0%} of the axis {y0:g} … {y1:g} (a flat line, not the data)"
            )
    return problems
