"""How the per-method tables of `core.experiments.flag_goals` and `core.experiments.noisy_tv_table` print:
one Markdown table (what docs/results.md quotes) or one JSON line per method."""

from __future__ import annotations

import json
from typing import Any


def print_table(table: dict[str, Any], header: str, rows: list[str], markdown: bool) -> None:
    """With ``markdown``, ``header``, its separator and ``rows``; else each method's row of ``table`` as a
    JSON line ``{"method": label, ...}``."""
    if markdown:
        separator = "|" + "---|" * (header.count(" | ") + 1)
        print("\n".join([header, separator, *rows]))
        return
    for label, row in table.items():
        print(json.dumps({"method": label, **row}))
