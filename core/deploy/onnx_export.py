"""ONNX export of the deployable policy μ(f(s)) — encoder + actor as one graph — checked against PyTorch.

The graph takes the camera image exactly as the robot delivers it: uint8 ``[N, 32, 64, 3]`` RGB (HWC), with
a dynamic batch axis ``N``; the conversion to float CHW in [0, 1] is inside the graph (``modelfree.networks
.to_float_chw``), and so is the action scale (a registered buffer of ``Actor``). The output is ``[N,
action_dim]``: ``[N, 1]`` (shoulder change) for the default ``hand="auto"`` policies, ``[N, 2]`` (shoulder
change, close) for ``hand="learned"`` policies. A policy of another gymnasium task takes that task's
observations (uint8 images of its size, or float32 vectors, scaled inside the graph) and answers in the
env's own action units (``ActionBounds`` is the graph's last node); its parity check runs on random
inputs within the observation space's bounds, and the metadata records the env id and action bounds.

The model's ``metadata_props`` record the opset, the input/output names and shapes, the action dimension, the
hand mode, the source checkpoint and the parity figures, so a deployment reads everything it needs from the
file (``OnnxPolicy`` does).

Verification at export (a failed check raises :class:`OnnxParityError` and writes nothing): onnxruntime runs
the exported graph on ``random_images`` uniformly random uint8 images and ``env_images`` NicoGrasp images
(half from the sim camera, half from the real-camera stand-in), at batch sizes 1, 64 and all at once; every
output must match the PyTorch policy within ``tolerance`` (max absolute difference, default 1e-4).

Decision: the TorchScript-based exporter (``torch.onnx.export(..., dynamo=False)``) is used: it needs no
extra package (the torch.export-based exporter needs ``onnxscript``) and handles this small static graph
exactly; its deprecation warning is silenced here.
"""

from __future__ import annotations

import io
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import NICO_GRASP_ID
from core.deploy.env_images import render_env_images
from core.envs.spec import EnvSpec
from core.modelfree.networks import PolicyNetwork
from core.runs.policy import Policy, load_policy
from core.runs.run_dir import atomic_write_bytes

DEFAULT_OPSET = 17
INPUT_NAME = "obs"
OUTPUT_NAME = "action"
PARITY_TOLERANCE = 1e-4
PARITY_BATCH_SIZES = (1, 64)
"""Batch sizes the parity check runs besides the whole image set in one call."""


class OnnxParityError(RuntimeError):
    """onnxruntime's outputs differ from PyTorch's beyond the tolerance: the export is not usable."""


class OnnxExportError(ValueError):
    """A user-caused export problem (bad output path, bad option)."""


@dataclass(frozen=True)
class ExportReport:
    """What ``export_onnx`` wrote and how it was checked."""

    path: Path
    opset: int
    input_name: str
    output_name: str
    action_dim: int
    max_abs_diff: float
    random_images: int
    env_images: int
    batch_sizes: tuple[int, ...]
    metadata: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "path": str(self.path),
            "opset": self.opset,
            "input_name": self.input_name,
            "output_name": self.output_name,
            "action_dim": self.action_dim,
            "max_abs_diff": self.max_abs_diff,
            "random_images": self.random_images,
            "env_images": self.env_images,
            "batch_sizes": list(self.batch_sizes),
            "metadata": dict(self.metadata),
        }


def onnx_bytes(
    network: PolicyNetwork, obs_shape: tuple[int, ...], opset: int = DEFAULT_OPSET, obs_dtype: str = "uint8"
) -> bytes:
    """The policy network as an ONNX model (bytes): ``[N, *obs_shape]`` (uint8 images, float32 vectors) →
    ``[N, action_dim]`` in the env's units."""
    network = network.eval()
    example = torch.zeros((2, *obs_shape), dtype=torch.uint8 if obs_dtype == "uint8" else torch.float32)
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            network,
            (example,),
            buffer,
            dynamo=False,
            opset_version=opset,
            input_names=[INPUT_NAME],
            output_names=[OUTPUT_NAME],
            dynamic_axes={INPUT_NAME: {0: "batch"}, OUTPUT_NAME: {0: "batch"}},
        )
    return buffer.getvalue()


def with_metadata(model_bytes: bytes, metadata: dict[str, str]) -> bytes:
    """The same model with ``metadata`` added to its ``metadata_props``."""
    import onnx

    model = onnx.load_from_string(model_bytes)
    for key, value in metadata.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, str(value)
    onnx.checker.check_model(model)
    return model.SerializeToString()


def check_onnx_parity(
    model: bytes | Path,
    network: PolicyNetwork,
    images: np.ndarray,
    *,
    tolerance: float = PARITY_TOLERANCE,
    batch_sizes: tuple[int, ...] = PARITY_BATCH_SIZES,
) -> float:
    """Max |onnxruntime − PyTorch| over ``images`` per batch size and all at once; raises above tolerance."""
    import onnxruntime

    source = str(model) if isinstance(model, Path) else model
    session = onnxruntime.InferenceSession(source, providers=["CPUExecutionProvider"])
    images = np.ascontiguousarray(images)
    with torch.no_grad():
        expected = network.eval()(torch.from_numpy(images)).numpy()
    worst = 0.0
    for batch in (*batch_sizes, len(images)):
        chunks = [
            session.run([OUTPUT_NAME], {INPUT_NAME: images[i : i + batch]})[0]
            for i in range(0, len(images), batch)
        ]
        got = np.concatenate(chunks)
        if got.shape != expected.shape:
            raise OnnxParityError(
                f"onnxruntime output shape {list(got.shape)} at batch {batch} differs from "
                f"PyTorch's {list(expected.shape)}"
            )
        diff = float(np.max(np.abs(got - expected)))
        if not np.isfinite(diff) or diff > tolerance:
            raise OnnxParityError(
                f"ONNX parity check failed: max |onnxruntime - PyTorch| = {diff:.3g} at "
                f"batch {batch} exceeds {tolerance:g}"
            )
        worst = max(worst, diff)
    return worst


def parity_images(
    obs_shape: tuple[int, ...], *, random_images: int, env_images: int, seed: int
) -> np.ndarray:
    """``random_images`` uniform uint8 images followed by ``env_images`` NicoGrasp images (both cameras)."""
    rng = np.random.default_rng(seed)
    parts = [rng.integers(0, 256, size=(random_images, *obs_shape), dtype=np.uint8)]
    if env_images > 0:
        parts.append(render_env_images(env_images, seed=seed))
    return np.concatenate(parts)


def parity_vectors(spec: EnvSpec, *, count: int, seed: int) -> np.ndarray:
    """``count`` float32 observations: uniform within the space's bounds where finite, else N(0, 3²)."""
    rng = np.random.default_rng(seed)
    shape = (count, *spec.obs_shape)
    if spec.obs_low is not None and spec.obs_high is not None:
        low, high = np.asarray(spec.obs_low), np.asarray(spec.obs_high)
        return rng.uniform(low, high, size=shape).astype(np.float32)
    return rng.normal(0.0, 3.0, size=shape).astype(np.float32)


def export_policy(
    policy: Policy,
    *,
    out: Path | str,
    opset: int = DEFAULT_OPSET,
    random_images: int = 256,
    env_images: int = 256,
    tolerance: float = PARITY_TOLERANCE,
    seed: int = 0,
) -> ExportReport:
    """Export a loaded policy to ``out`` after the parity check (see the module docstring)."""
    out = Path(out)
    if out.is_dir():
        raise OnnxExportError(f"--out {out} is a directory; give a file name such as policy.onnx")
    if random_images < 0 or env_images < 0 or random_images + env_images < 1:
        raise OnnxExportError("the parity check needs at least one image")
    if opset < 13:
        raise OnnxExportError(f"opset {opset} is too old; use 13 or newer")
    spec = policy.spec
    obs_shape = policy.obs_shape
    nico = policy.config.env.id == NICO_GRASP_ID
    if not nico:
        env_images = 0  # NicoGrasp's renderings mean nothing to another task's policy
        if random_images < 1:
            raise OnnxExportError("the parity check needs at least one input (random_images >= 1)")
    elif tuple(obs_shape) != (32, 64, 3) and env_images > 0:
        raise OnnxExportError(f"environment images are 32x64x3 but the policy takes {list(obs_shape)}")
    low, high = spec.bounds()
    metadata = {
        "producer": "dualsys",
        "opset": str(opset),
        "env_id": policy.config.env.id,
        "env_kwargs": json.dumps(policy.config.env.kwargs),
        "env_success": policy.config.env.success,
        "input_name": INPUT_NAME,
        "input_shape": f"[N, {', '.join(map(str, obs_shape))}]",
        "input_dtype": "uint8" if spec.obs_kind == "image" else "float32",
        "input_layout": (
            "NHWC, 0-255; scaled to [0, 1] inside the graph"
            if spec.obs_kind == "image"
            else "the env's observation vector; scaled by its bounds inside the graph"
        ),
        "output_name": OUTPUT_NAME,
        "output_shape": f"[N, {policy.action_dim}]",
        "action_dim": str(policy.action_dim),
        "action_low": json.dumps([float(v) for v in low]),
        "action_high": json.dumps([float(v) for v in high]),
        "source_checkpoint": str(policy.source),
    }
    if nico:
        close = ", close if > 0" if policy.action_dim == 2 else ""
        metadata["action_meaning"] = f"shoulder change x 20 deg{close}"
        metadata["hand"] = str(policy.config.env.hand)
        metadata["level"] = policy.config.env.level
    model = onnx_bytes(policy.network, obs_shape, opset, "uint8" if spec.obs_kind == "image" else "float32")
    if spec.obs_kind == "image":
        images = parity_images(obs_shape, random_images=random_images, env_images=env_images, seed=seed)
    else:
        images = parity_vectors(spec, count=random_images, seed=seed)
    max_diff = check_onnx_parity(model, policy.network, images, tolerance=tolerance)
    metadata.update(
        {
            "parity_max_abs_diff": f"{max_diff:.3g}",
            "parity_tolerance": f"{tolerance:g}",
            "parity_images": f"{random_images} random + {env_images} environment",
        }
    )
    final = with_metadata(model, metadata)
    check_onnx_parity(final, policy.network, images[:64], tolerance=tolerance, batch_sizes=(1,))
    atomic_write_bytes(out, final)
    out.chmod(0o644)
    return ExportReport(
        path=out,
        opset=opset,
        input_name=INPUT_NAME,
        output_name=OUTPUT_NAME,
        action_dim=policy.action_dim,
        max_abs_diff=max_diff,
        random_images=random_images,
        env_images=env_images,
        batch_sizes=(*PARITY_BATCH_SIZES, len(images)),
        metadata=metadata,
    )


def export_onnx(
    *,
    policy_path: Path | str,
    out: Path | str,
    opset: int = DEFAULT_OPSET,
    random_images: int = 256,
    env_images: int = 256,
    tolerance: float = PARITY_TOLERANCE,
    seed: int = 0,
) -> ExportReport:
    """Load the policy of a run directory or checkpoint and export it (``dualsys export``, export jobs)."""
    return export_policy(
        load_policy(policy_path),
        out=out,
        opset=opset,
        random_images=random_images,
        env_images=env_images,
        tolerance=tolerance,
        seed=seed,
    )
