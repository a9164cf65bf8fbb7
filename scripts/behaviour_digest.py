"""Digests of 16 short runs: the check that a restructure of the training code changed no behaviour.

Run it before and after a change (each in its own output folder) and compare the two JSON files; every
digest must match, except where the change means to move a method (then say which, and why). What it runs:

- MountainCarContinuous-v0, 2 500 env steps, every ``--algo`` of the method registry (10 runs);
- ``im2c --ac cacla``, ``i2a --ac sac``, and ``im2c`` / ``i2a`` under the ``paper`` profile (4 runs);
- NicoGrasp (``released`` level) 12 episodes: ``i2a`` sparse and ``im2c`` dense (2 runs);
- ``dualsys diagnose mechanisms --quick --json`` on the ``default`` and ``paper`` profiles.

A run's digest is the SHA-256 of its metrics.csv without the wall-clock columns (``time/wall_s``,
``charts/sps``), its columns in name order (the file's order is the order keys first appeared).
``--compare A B`` names, for each run whose digests differ, the columns whose values differ. Runs are
single-threaded (``OMP_NUM_THREADS=1``), so a digest is exact on one machine; across machines it depends on
the CPU's instruction set (docs/experiments.md, "Portable runs").

    python scripts/behaviour_digest.py OUT_DIR [--only NAME ...] [--workers 2]
    python scripts/behaviour_digest.py --compare BEFORE_DIR AFTER_DIR
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

WALL_CLOCK_COLUMNS = ("time/wall_s", "charts/sps")
MOUNTAINCAR = ["--env", "MountainCarContinuous-v0", "--steps", "2500"]
ALGOS = ("ddpg", "cacla", "td3", "sac", "im2c", "i2a", "cmc", "la-imagination", "mve", "rnd")

RUNS: dict[str, list[str]] = {
    **{f"mc-{algo}": ["--algo", algo, *MOUNTAINCAR] for algo in ALGOS},
    "mc-im2c-cacla": ["--algo", "im2c", "--ac", "cacla", *MOUNTAINCAR],
    "mc-i2a-sac": ["--algo", "i2a", "--ac", "sac", *MOUNTAINCAR],
    "mc-im2c-paper": ["--algo", "im2c", "--profile", "paper", *MOUNTAINCAR],
    "mc-i2a-paper": ["--algo", "i2a", "--profile", "paper", *MOUNTAINCAR],
    "grasp-i2a-sparse": ["--algo", "i2a", "--reward", "sparse", "--episodes", "12"],
    "grasp-im2c-dense": ["--algo", "im2c", "--reward", "dense", "--episodes", "12"],
}
CHECKS: dict[str, list[str]] = {
    "mechanisms-default": ["diagnose", "mechanisms", "--quick", "--json"],
    "mechanisms-paper": ["diagnose", "mechanisms", "--quick", "--json", "--profile", "paper"],
}


def metrics_columns(path: Path) -> dict[str, list[str]]:
    """A metrics.csv's columns by name, without the wall-clock ones."""
    rows = list(csv.reader(path.read_text().splitlines()))
    return {name: [row[i] for row in rows[1:]] for i, name in enumerate(rows[0])
            if name not in WALL_CLOCK_COLUMNS}


def metrics_digest(path: Path) -> str:
    """SHA-256 of a metrics.csv with the wall-clock columns removed, columns in name order."""
    columns = metrics_columns(path)
    buffer = io.StringIO()
    csv.writer(buffer).writerows([[name, *columns[name]] for name in sorted(columns)])
    return hashlib.sha256(buffer.getvalue().encode()).hexdigest()


def compare(before: Path, after: Path) -> dict[str, object]:
    """For each run: "same", or the columns whose values differ (and those only one side has)."""
    old = json.loads((before / "digests.json").read_text())
    new = json.loads((after / "digests.json").read_text())
    result: dict[str, object] = {}
    for name in old:
        if name not in new:
            result[name] = "missing after"
        elif old[name] == new[name]:
            result[name] = "same"
        elif name in CHECKS:
            result[name] = "differs"
        else:
            a = metrics_columns(before / name / "metrics.csv")
            b = metrics_columns(after / name / "metrics.csv")
            result[name] = {"differ": sorted(k for k in a.keys() & b.keys() if a[k] != b[k]),
                            "only_before": sorted(a.keys() - b.keys()),
                            "only_after": sorted(b.keys() - a.keys())}
    return result


def check_digest(text: str) -> str:
    """SHA-256 of a mechanisms report with its timing fields removed."""
    report = json.loads(text.strip().splitlines()[-1])

    def strip(value: object) -> object:
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if "seconds" not in k and k != "wall_s"}
        if isinstance(value, list):
            return [strip(v) for v in value]
        return value

    return hashlib.sha256(json.dumps(strip(report), sort_keys=True).encode()).hexdigest()


def dualsys() -> list[str]:
    return [sys.executable, "-m", "dualsys_cli.main"]


def run_one(name: str, out: Path) -> tuple[str, str]:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    if name in CHECKS:
        done = subprocess.run([*dualsys(), *CHECKS[name]], capture_output=True, text=True, env=env,
                              check=True)
        (out / f"{name}.json").write_text(done.stdout)
        return name, check_digest(done.stdout)
    run_dir = out / name
    subprocess.run([*dualsys(), "train", *RUNS[name], "--out", str(run_dir), "--json"],
                   capture_output=True, text=True, env=env, check=True)
    return name, metrics_digest(run_dir / "metrics.csv")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path, nargs="?")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    parser.add_argument("--only", nargs="*", default=None, help="run only these names")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    if args.compare:
        print(json.dumps(compare(*args.compare), indent=1))
        return
    if args.out is None:
        parser.error("give OUT_DIR or --compare BEFORE AFTER")
    args.out.mkdir(parents=True, exist_ok=True)
    names = args.only or [*RUNS, *CHECKS]
    with ThreadPoolExecutor(args.workers) as pool:
        digests = dict(pool.map(lambda name: run_one(name, args.out), names))
    result = {name: digests[name] for name in names}
    (args.out / "digests.json").write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
