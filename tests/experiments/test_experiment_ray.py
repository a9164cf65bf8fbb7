"""`--ray`: cells as Ray tasks on a real two-node cluster that this module starts with `ray start`.

Both nodes run on this machine (`ray start --head`, then `ray start --address`), one CPU each, with
token authentication (`RAY_AUTH_MODE=token`). The token is this module's own file (`RAY_AUTH_TOKEN_PATH`,
instead of the default ~/.ray/auth_token) and the cluster keeps its sessions in its own temporary
folder; teardown ends the process groups of the two `ray start` calls (and any process still naming the
folder), not every Ray process of the machine as `ray stop` would.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("ray", reason="Ray is an optional extra (pip install 'dualsys[ray]')")


ROOT = Path(__file__).resolve().parents[2]


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _processes_naming(text: str) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if text in (entry / "cmdline").read_bytes().decode(errors="replace"):
                    found.append(int(entry.name))
            except OSError:
                continue
    return found


@pytest.fixture(scope="module")
def ray_cluster() -> Iterator[tuple[str, dict[str, str]]]:
    ray_bin = Path(sys.executable).with_name("ray")
    folder = Path(tempfile.mkdtemp(prefix="rt", dir="/tmp"))  # short: Ray's socket paths must fit 107 bytes
    token = folder / "auth_token"
    token.write_text(secrets.token_hex(32))
    env = {
        **os.environ,
        "RAY_AUTH_MODE": "token",
        "RAY_AUTH_TOKEN_PATH": str(token),
        "PYTHONPATH": str(ROOT),
        "OMP_NUM_THREADS": "1",
        # The cells' worker processes run at the lowest priority; Ray's own daemons keep the caller's
        # (under `nice -n 19` on a loaded machine they miss Ray's start-up deadlines).
        "RAY_worker_niceness": "19",
    }
    port = _free_port()
    address = f"127.0.0.1:{port}"
    groups: list[int] = []

    def start(*args: str) -> None:
        command = [str(ray_bin), "start", *args, "--num-cpus=1", "--disable-usage-stats"]
        process = subprocess.Popen(
            command,
            env=env,
            start_new_session=True,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        groups.append(process.pid)  # its daemons stay in this process group after it exits
        output, _ = process.communicate(timeout=240)
        if process.returncode != 0:
            pytest.fail(f"{' '.join(command)} failed:\n{output[-3000:]}")

    try:
        start(
            "--head",
            f"--port={port}",
            "--node-ip-address=127.0.0.1",
            "--include-dashboard=false",
            f"--dashboard-port={_free_port()}",
            f"--temp-dir={folder}",
        )
        start(f"--address={address}", "--node-ip-address=127.0.0.1")
        yield address, env
    finally:
        for group in groups:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(group, signal.SIGTERM)
        deadline = time.monotonic() + 5
        while _processes_naming(str(folder)) and time.monotonic() < deadline:
            time.sleep(0.5)
        for group in groups:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(group, signal.SIGKILL)
        for pid in _processes_naming(str(folder)):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        shutil.rmtree(folder, ignore_errors=True)


def run_cli(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    """`dualsys experiment run ...` as its own process: Ray reads the token settings when it is imported."""
    command = [str(Path(sys.executable).with_name("dualsys")), "experiment", "run", *args, "--json"]
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.timeout(1800)  # four cells on a shared, loaded 2-core machine: minutes waiting for a core
def test_two_node_cluster_runs_a_tiny_grid(ray_cluster, tmp_path, write_experiment) -> None:
    address, env = ray_cluster
    path = write_experiment(
        methods=[{"label": "DDPG", "algo": "ddpg"}, {"label": "CACLA", "algo": "cacla"}], steps=60
    )
    out = tmp_path / "out"
    finished = run_cli(env, str(path), "--out", str(out), "--ray", address)
    assert finished.returncode == 0, finished.stderr[-3000:]
    result = json.loads(finished.stdout.strip().splitlines()[-1])
    cells = sorted(f"{m}/dense/seed-{s}" for m in ("DDPG", "CACLA") for s in (0, 1))
    assert result["complete"] and sorted(result["done"]) == cells
    nodes = {result["workers"][key].split(" node ")[1].split()[0] for key in cells}
    assert len(nodes) == 2, result["workers"]  # both nodes ran cells
    for key in cells:
        run_dir = out / "tiny" / key
        summary = json.loads((run_dir / "summary.json").read_text())
        assert summary["stopped"] is False and summary["steps"] >= 60
        assert (run_dir / "checkpoints" / "best.pt").is_file()
    again = run_cli(env, str(path), "--out", str(out), "--ray", address)
    assert again.returncode == 0 and sorted(json.loads(again.stdout.splitlines()[-1])["skipped"]) == cells
