"""ONNX export: parity with PyTorch at batch 1 and 64, metadata, dynamic batch, failure paths."""

from __future__ import annotations

import numpy as np
import onnx
import pytest
import torch

from core.deploy import (
    OnnxExportError,
    OnnxParityError,
    OnnxPolicy,
    OnnxPolicyError,
    check_onnx_parity,
    evaluate_policy,
    export_onnx,
    render_env_images,
)
from core.deploy.onnx_export import onnx_bytes
from core.runs.policy import PolicyLoadError, load_policy


@pytest.fixture(scope="module")
def exported(tiny_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("onnx") / "policy.onnx"
    report = export_onnx(policy_path=tiny_run, out=out, random_images=64, env_images=32)
    return report


def test_export_writes_metadata_and_a_dynamic_uint8_batch_axis(exported, tiny_run):
    model = onnx.load(str(exported.path))
    meta = {p.key: p.value for p in model.metadata_props}
    assert meta["opset"] == "17" == str(exported.opset)
    assert model.opset_import[0].version == 17
    assert meta["input_name"] == "obs" and meta["output_name"] == "action"
    assert meta["action_dim"] == "1" and meta["hand"] == "auto"
    assert float(meta["parity_max_abs_diff"]) <= 1e-4
    (graph_input,) = model.graph.input
    dims = graph_input.type.tensor_type.shape.dim
    assert graph_input.name == "obs" and graph_input.type.tensor_type.elem_type == onnx.TensorProto.UINT8
    assert dims[0].dim_param and [d.dim_value for d in dims[1:]] == [32, 64, 3]
    assert exported.max_abs_diff <= 1e-4 and exported.batch_sizes == (1, 64, 96)


@pytest.mark.parametrize("batch", [1, 64])
def test_onnxruntime_matches_pytorch_on_random_and_env_images(exported, tiny_run, batch):
    policy = load_policy(tiny_run)
    runner = OnnxPolicy(exported.path)
    assert (runner.input_name, runner.output_name, runner.action_dim) == ("obs", "action", 1)
    rng = np.random.default_rng(batch)
    for images in (rng.integers(0, 256, size=(batch, 32, 64, 3), dtype=np.uint8),
                   render_env_images(batch, seed=batch)):
        got = runner.act(images)
        assert got.shape == (batch, 1)
        np.testing.assert_allclose(got, policy.act(images), atol=1e-4, rtol=0)


def test_learned_hand_policy_exports_two_actions(tiny_learned_run, tmp_path):
    report = export_onnx(policy_path=tiny_learned_run, out=tmp_path / "learned.onnx", random_images=16,
                         env_images=8)
    runner = OnnxPolicy(report.path)
    assert report.action_dim == runner.action_dim == 2 and runner.hand == "learned"
    images = render_env_images(5, seed=1)
    assert runner.act(images).shape == (5, 2)
    np.testing.assert_allclose(runner.act(images), load_policy(tiny_learned_run).act(images), atol=1e-4)


def test_parity_check_raises_when_the_graph_and_the_network_differ(tiny_run):
    policy = load_policy(tiny_run)
    model = onnx_bytes(policy.network, policy.obs_shape)
    images = np.random.default_rng(0).integers(0, 256, size=(8, 32, 64, 3), dtype=np.uint8)
    assert check_onnx_parity(model, policy.network, images) <= 1e-4
    with torch.no_grad():
        policy.network.actor.net[-2].bias.add_(0.5)
    with pytest.raises(OnnxParityError, match="parity check failed"):
        check_onnx_parity(model, policy.network, images)


def test_a_failed_check_writes_nothing_and_bad_inputs_raise(tiny_run, tmp_path):
    out = tmp_path / "policy.onnx"
    with pytest.raises(OnnxParityError):
        export_onnx(policy_path=tiny_run, out=out, random_images=8, env_images=0, tolerance=-1.0)
    assert not out.exists() and list(tmp_path.iterdir()) == []
    with pytest.raises(OnnxExportError, match="directory"):
        export_onnx(policy_path=tiny_run, out=tmp_path, random_images=8, env_images=0)
    with pytest.raises(PolicyLoadError):
        export_onnx(policy_path=tmp_path / "missing", out=out)
    (tmp_path / "junk.onnx").write_bytes(b"not a model")
    with pytest.raises(OnnxPolicyError):
        OnnxPolicy(tmp_path / "junk.onnx")
    with pytest.raises(OnnxPolicyError):
        OnnxPolicy(tmp_path / "absent.onnx")


def test_eval_through_onnx_gives_the_same_trials_as_pytorch(tiny_run, exported):
    torch_report = evaluate_policy(policy_path=tiny_run, trials=3, max_steps=4, seed=5)
    onnx_report = evaluate_policy(policy_path=exported.path, trials=3, max_steps=4, seed=5)
    assert onnx_report.per_trial == torch_report.per_trial


def test_eval_with_onnx_flag_exports_a_checkpoint_on_the_fly(tiny_run):
    torch_report = evaluate_policy(policy_path=tiny_run, trials=2, max_steps=3, seed=9, domain="real")
    onnx_report = evaluate_policy(policy_path=tiny_run, trials=2, max_steps=3, seed=9, domain="real",
                                  onnx=True)
    assert onnx_report.per_trial == torch_report.per_trial
    with pytest.raises(ValueError, match="unknown domain"):
        evaluate_policy(policy_path=tiny_run, trials=1, domain="lab")
