"""Run an exported policy with onnxruntime: observations ``[N, *obs_shape]`` (uint8 NicoGrasp images
``[N, 32, 64, 3]``, or another task's images or float32 vectors) → actions ``[N, action_dim]`` in the env's
units.

Input and output names, the action dimension, the env id and kwargs, and the hand mode are read from the
model's metadata (written by :mod:`core.deploy.onnx_export`); a model without them falls back to the
graph's first input/output and NicoGrasp.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from core.config import NICO_GRASP_ID
from core.runs.policy import observation_batch


class OnnxPolicyError(ValueError):
    """The file is not a loadable ONNX policy."""


class OnnxPolicy:
    """An ONNX policy on onnxruntime's CPU provider."""

    def __init__(self, path: Path | str, *, threads: int | None = None) -> None:
        import onnxruntime

        self.path = Path(path)
        if not self.path.is_file():
            raise OnnxPolicyError(f"ONNX policy not found: {self.path}")
        options = onnxruntime.SessionOptions()
        if threads is not None:
            options.intra_op_num_threads = int(threads)
            options.inter_op_num_threads = 1
        try:
            self.session = onnxruntime.InferenceSession(
                str(self.path), options, providers=["CPUExecutionProvider"]
            )
        except Exception as exc:  # onnxruntime raises its own exception types for a bad file
            raise OnnxPolicyError(f"cannot load ONNX policy {self.path}: {exc}".splitlines()[0]) from None
        self.metadata: dict[str, str] = dict(self.session.get_modelmeta().custom_metadata_map)
        self.input_name = self.metadata.get("input_name", self.session.get_inputs()[0].name)
        self.output_name = self.metadata.get("output_name", self.session.get_outputs()[0].name)
        graph_input = self.session.get_inputs()[0]
        self.obs_shape = tuple(int(v) for v in graph_input.shape[1:])
        self.obs_dtype = "uint8" if graph_input.type == "tensor(uint8)" else "float32"
        self.env_id = self.metadata.get("env_id", NICO_GRASP_ID)
        self.env_kwargs: dict = json.loads(self.metadata.get("env_kwargs", "{}"))
        self.env_success = self.metadata.get("env_success", "info")
        """The training run's ``env.success`` rule (exports from before it: info)."""
        output_dim = self.session.get_outputs()[0].shape[-1]
        self.action_dim = int(self.metadata.get("action_dim", output_dim))
        self.hand = self.metadata.get("hand", "auto" if self.action_dim == 1 else "learned")
        self.level = self.metadata.get("level", "released")
        """Task level the policy was trained on (exports from before task levels: released)."""

    def act(self, obs: np.ndarray) -> np.ndarray:
        """Actions for observations ``[N, *obs_shape]`` (or one ``obs_shape`` → ``[1, A]``)."""
        batch = observation_batch(obs, self.obs_shape, self.obs_dtype)
        return self.session.run([self.output_name], {self.input_name: batch})[0]
