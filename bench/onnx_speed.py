"""Per-image inference latency of the deployable policy: onnxruntime vs PyTorch (``dualsys bench onnx``).

The policy is a trained one (``policy``: run directory or checkpoint) or, by default, a freshly initialised
network of the default profile's architecture (latency does not depend on the weights). Both runtimes get
the same thread count (default 1: a robot's control loop shares its computer). Reported per image: the
median over ``repeats`` calls at batch 1 (the deployment case: one camera image per grasp step), and at
batch 64 divided by 64. Goal: onnxruntime ≤ 1 ms per image at batch 1.
"""

from __future__ import annotations

import platform
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch

GOAL_MS = 1.0


def _median_ms(call: Callable[[], object], repeats: int) -> float:
    for _ in range(max(5, repeats // 20)):
        call()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e3


def measure(policy: Path | str | None = None, repeats: int = 2000, threads: int = 1) -> dict:
    """Latency figures as a JSON-ready dict (see the module docstring)."""
    import onnxruntime

    from core.config import Config
    from core.deploy.onnx_export import onnx_bytes
    from core.deploy.onnx_policy import OnnxPolicy
    from core.modelfree.networks import OBS_SHAPE, Actor, Encoder, PolicyNetwork
    from core.runs.policy import load_policy

    if repeats < 1 or threads < 1:
        raise ValueError("repeats and threads must be >= 1")
    torch.set_num_threads(threads)
    if policy is not None:
        loaded = load_policy(policy)
        network, obs_shape, arch = loaded.network.eval(), loaded.obs_shape, loaded.config.net.arch
    else:
        config = Config()
        torch.manual_seed(0)
        net = config.net
        actor = Actor(net.latent_dim, 1, (net.actor_hidden,), net.actor_activation)
        network = PolicyNetwork(Encoder(net), actor).eval()
        obs_shape, arch = OBS_SHAPE, config.net.arch
    rng = np.random.default_rng(0)
    one = rng.integers(0, 256, size=(1, *obs_shape), dtype=np.uint8)
    many = rng.integers(0, 256, size=(64, *obs_shape), dtype=np.uint8)
    with tempfile.TemporaryDirectory(prefix="dualsys-bench-") as folder:
        path = Path(folder) / "policy.onnx"
        path.write_bytes(onnx_bytes(network, obs_shape))
        runner = OnnxPolicy(path, threads=threads)
        onnx_1 = _median_ms(lambda: runner.act(one), repeats)
        onnx_64 = _median_ms(lambda: runner.act(many), max(1, repeats // 10)) / 64
    one_t, many_t = torch.from_numpy(one), torch.from_numpy(many)
    with torch.inference_mode():
        torch_1 = _median_ms(lambda: network(one_t), repeats)
        torch_64 = _median_ms(lambda: network(many_t), max(1, repeats // 10)) / 64
    return {
        "policy": str(policy) if policy is not None else f"untrained default-profile network ({arch})",
        "threads": threads,
        "repeats": repeats,
        "onnx_ms_per_image_batch1": round(onnx_1, 4),
        "torch_ms_per_image_batch1": round(torch_1, 4),
        "speedup_batch1": round(torch_1 / onnx_1, 2),
        "onnx_ms_per_image_batch64": round(onnx_64, 4),
        "torch_ms_per_image_batch64": round(torch_64, 4),
        "goal_ms": GOAL_MS,
        "meets_goal": onnx_1 <= GOAL_MS,
        "onnxruntime": onnxruntime.__version__,
        "torch": torch.__version__,
        "cpu": platform.processor() or platform.machine(),
    }


if __name__ == "__main__":  # pragma: no cover
    import json

    print(json.dumps(measure()))
