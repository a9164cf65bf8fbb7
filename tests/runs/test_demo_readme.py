"""README's "What `make demo` prints" against the current code (issue 51).

* The commands the README quotes for `make demo` are the Makefile's `demo` recipe, line for line.
* The README's one-minute check (the demo's training command with a short `--steps` budget and `--json`)
  runs here and must print the figures the README quotes, to the digits quoted. The check pins its CPU
  kernels (`run.cpu_isa=avx2`), so it reproduces bit for bit on any x86-64 machine with AVX2; without AVX2
  it is skipped.
* With DUALSYS_FULL_DEMO=1 the full demo runs too (minutes) and its training summary and calibration must
  be the README's table figures.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from core.runs import cpu_isa

ROOT = Path(__file__).resolve().parents[2]
SECTION = "### What `make demo` prints"

needs_avx2 = pytest.mark.skipif(
    cpu_isa.host_problem("avx2") is not None, reason=str(cpu_isa.host_problem("avx2"))
)


def _section() -> str:
    text = (ROOT / "README.md").read_text()
    start = text.index(SECTION)
    end = text.find("\n## ", start)
    return text[start : end if end != -1 else len(text)]


def _bash_blocks(section: str) -> list[list[str]]:
    """The ```bash blocks of the section, each as its command lines."""
    blocks = re.findall(r"```bash\n(.*?)```", section, flags=re.S)
    return [[line.strip() for line in block.splitlines() if line.strip()] for block in blocks]


def _makefile_demo() -> list[str]:
    """The Makefile's `demo` recipe, `$(BIN)/` dropped (the commands a user types in the venv)."""
    lines = (ROOT / "Makefile").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("demo:"))
    recipe = []
    for line in lines[start + 1 :]:
        if not line.startswith("\t"):
            break
        recipe.append(line.strip().replace("$(BIN)/", ""))
    return recipe


def _quoted_check() -> tuple[list[str], dict[str, str]]:
    """The check's command and the figures the README says it prints on this host's CPU vendor (as written:
    their digits; `cpu_isa.cpu_vendor`: the pin fixes the instruction set, not the vendor's kernels)."""
    section = _section()
    command = _bash_blocks(section)[1]
    assert len(command) == 1, command
    tail = section[section.index(command[0]) :]
    vendor = {"amd": "AMD EPYC", "intel": "Intel Xeon"}.get(cpu_isa.cpu_vendor(), "AMD EPYC")
    printed = re.search(rf"on an {vendor}:\n\n```json\n(.*?)```", tail, flags=re.S)
    assert printed, f"the README quotes the check's printed JSON line on an {vendor} in a ```json block"
    figures = dict(re.findall(r'"(\w+)": (-?[0-9.]+)', printed.group(1)))
    return shlex.split(command[0]), figures


def _options(args: list[str]) -> list[str]:
    """A train command's arguments without its budget (--steps N) and --json."""
    kept, skip = [], False
    for arg in args:
        if skip:
            skip = False
        elif arg == "--steps":
            skip = True
        elif arg != "--json":
            kept.append(arg)
    return kept


def _agrees(value: float | int, quoted: str) -> bool:
    """``value`` printed with as many decimals as ``quoted`` has is ``quoted``."""
    decimals = len(quoted.split(".")[1]) if "." in quoted else 0
    return f"{value:.{decimals}f}" == quoted


def _run(args: list[str], timeout: float) -> str:
    env = {k: v for k, v in os.environ.items() if k not in cpu_isa.CPU_ISA_KEYS}
    env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    done = subprocess.run(
        [sys.executable, "-m", "dualsys_cli.main", *args],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def _last_json(stdout: str) -> dict:
    return json.loads(stdout.strip().splitlines()[-1])


def test_the_readme_quotes_the_makefiles_demo_and_its_check():
    demo = _bash_blocks(_section())[0]
    assert demo == _makefile_demo(), "README's `make demo` commands are not the Makefile's demo recipe"
    check, figures = _quoted_check()
    # the check is the demo's training command with a short budget and --json
    assert check[:2] == ["dualsys", "train"] and check[-1] == "--json" and "--steps" in check
    assert _options(check) == _options(shlex.split(demo[0]))
    assert {"final_perf", "auc", "success_rate", "steps", "episodes"} <= set(figures)


@needs_avx2
def test_the_readmes_check_prints_the_readmes_figures(tmp_path):
    check, figures = _quoted_check()
    assert "run.cpu_isa=avx2" in check, "the check pins its kernels, so it reproduces on any AVX2 machine"
    summary = _last_json(_run([*check[1:], "--out", str(tmp_path / "run")], timeout=300))
    got = {key: summary[key] for key in figures}
    assert all(_agrees(summary[key], quoted) for key, quoted in figures.items()), (got, figures)


@needs_avx2
@pytest.mark.skipif(
    os.environ.get("DUALSYS_FULL_DEMO") != "1", reason="the full demo takes minutes: DUALSYS_FULL_DEMO=1"
)
def test_the_full_demo_prints_the_readmes_tables(tmp_path):
    train, calibrate = (shlex.split(line) for line in _bash_blocks(_section())[0])
    run_dir = tmp_path / "demo"
    _run([*train[1:], "--out", str(run_dir), "--json"], timeout=1200)
    summary = json.loads((run_dir / "summary.json").read_text())
    row = re.search(r"\n\| ([0-9.]+) \| (-?[0-9.]+) \| (-?[0-9.]+) \| ([0-9 ]+) \| ([0-9 ]+) \|", _section())
    assert row, "the README's row: greedy success | Final Perf | AuC | env steps | episodes"
    success, final_perf, auc, steps, episodes = row.groups()
    assert _agrees(summary["success_rate"], success)
    assert _agrees(summary["final_perf"], final_perf) and _agrees(summary["auc"], auc)
    counts = (int(steps.replace(" ", "")), int(episodes.replace(" ", "")))
    assert (summary["steps"], summary["episodes"]) == counts
    calibration = _last_json(_run([*calibrate[1:], "--json"], timeout=600))
    quoted = re.findall(r"\| (oracle|random|best constant) \| ([0-9.]+) % \| ([0-9.]+) % \|", _section())
    assert [name for name, _, _ in quoted] == ["oracle", "random", "best constant"], quoted
    for name, success, toppled in quoted:
        rates = calibration[name.replace(" ", "_")]
        got = (f"{100 * rates['success']:.1f}", f"{100 * rates['toppled']:.1f}")
        assert got == (success, toppled), (name, rates)
