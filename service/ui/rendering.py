"""Jinja2 templates and static files of the dashboard, shipped inside the package (no CDN).

One Environment, built on first use: templates are compiled once per process and never re-read
(`auto_reload=False`), `autoescape` is on for every template, and a missing variable is an error
(`StrictUndefined`) rather than an empty cell. Static URLs carry a hash of the file
(`/ui/static/dashboard.js?v=1a2b3c4d`) and are served with a year-long cache lifetime, so a
browser fetches each script and style once per release.
"""

from __future__ import annotations

import hashlib
import json
from datetime import datetime
from functools import cache
from pathlib import Path
from typing import Any

from jinja2 import Environment, PackageLoader, StrictUndefined
from starlette.staticfiles import StaticFiles
from starlette.types import Scope

STATIC = Path(__file__).parent / "static"


@cache
def asset_versions() -> dict[str, str]:
    return {
        path.name: hashlib.sha256(path.read_bytes()).hexdigest()[:10]
        for path in sorted(STATIC.iterdir())
        if path.is_file()
    }


def static_url(name: str) -> str:
    return f"/ui/static/{name}?v={asset_versions()[name]}"


def number(value: Any, digits: int = 3) -> str:
    """A metric as a person reads it: ints as they are, floats to `digits` significant figures."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    return str(value)


def plain(value: Any) -> str:
    """A config or tag value as text: strings as they are, everything else as JSON."""
    if isinstance(value, str):
        return value
    return json.dumps(value, default=str)


def timestamp(value: datetime | None) -> str:
    return "" if value is None else value.strftime("%Y-%m-%d %H:%M:%S UTC")


def size(value: int | None) -> str:
    if value is None:
        return ""
    for unit in ("B", "kB", "MB", "GB"):
        if value < 1000 or unit == "GB":
            return f"{value} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1000  # type: ignore[assignment]
    return str(value)


@cache
def environment() -> Environment:
    env = Environment(
        loader=PackageLoader("service.ui", "templates"),
        autoescape=True,
        auto_reload=False,
        undefined=StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.globals["static_url"] = static_url
    env.globals["experiments_enabled"] = lambda: False  # install_dashboard asks the app
    env.filters.update(number=number, plain=plain, timestamp=timestamp, size=size)
    return env


def render(template: str, **context: Any) -> str:
    context.setdefault("title", "dualsys")
    context.setdefault("nav", "")
    context.setdefault("page_data", {})
    return environment().get_template(template).render(**context)


class _CachedStatic(StaticFiles):
    async def get_response(self, path: str, scope: Scope):  # type: ignore[no-untyped-def]
        response = await super().get_response(path, scope)
        if response.status_code == 200:
            response.headers["Cache-Control"] = "public, max-age=31536000, immutable"
        return response


def static_files() -> StaticFiles:
    return _CachedStatic(directory=STATIC)
