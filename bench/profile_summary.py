"""Where a service process spends its CPU: a summary of py-spy's raw (collapsed) recordings, as
`dualsys bench service --profile DIR` writes them. Prints JSON; `python -m bench.profile_summary DIR`.

py-spy samples every thread at a fixed rate, idle ones too (with `--nonblocking` and without `--idle` it
skips threads that wait in the kernel); the shares below are of the samples that had a Python frame
running. Two views: `self` (the innermost frame: where the interpreter is) and `inclusive` (any frame of
the stack: what the time was spent for), both by function and file, top N.
"""

from __future__ import annotations

import json
import re
import sys
from collections import Counter
from pathlib import Path
from typing import Any

FRAME = re.compile(r"^(?P<function>.+?) \((?P<file>.+?)(?::\d+)?\)$")


def _frames(stack: str) -> list[str]:
    """`function (path/to/file.py:12)` → `function (file.py)` for each frame of a collapsed stack."""
    frames = []
    for frame in stack.split(";"):
        match = FRAME.match(frame)
        if match is None:
            frames.append(frame)
            continue
        path = match["file"]
        short = "/".join(Path(path).parts[-2:]) if "site-packages" in path or "/" in path else path
        frames.append(f"{match['function']} ({short})")
    return frames


def summarise_file(path: Path, top: int = 25) -> dict[str, Any]:
    self_counts: Counter[str] = Counter()
    inclusive: Counter[str] = Counter()
    total = 0
    for line in path.read_text(errors="replace").splitlines():
        stack, _, count_text = line.rpartition(" ")
        if not stack or not count_text.isdigit():
            continue
        count = int(count_text)
        frames = _frames(stack)
        total += count
        self_counts[frames[-1]] += count
        for frame in set(frames):
            inclusive[frame] += count
    share = lambda counter: [  # noqa: E731 - one-line table builder
        {"frame": frame, "share": round(count / total, 3)} for frame, count in counter.most_common(top)
    ]
    return {"file": path.name, "samples": total, "self": share(self_counts), "inclusive": share(inclusive)}


def summarise(folder: Path, top: int = 25) -> list[dict[str, Any]]:
    return [summarise_file(path, top) for path in sorted(folder.glob("*.txt")) if path.stat().st_size]


if __name__ == "__main__":  # pragma: no cover
    print(json.dumps(summarise(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 25), indent=1))
