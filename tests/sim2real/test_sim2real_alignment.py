"""Sim-to-real alignment: L_Transfer, held-out distance goes down, actor untouched, atomic output, errors."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import torch

from core.envs import CameraShift
from core.runs.policy import PolicyLoadError, load_policy
from core.runs.run_dir import load_checkpoint
from sim2real import AlignmentError, PairDataError, align_encoder, generate_pairs, transfer_loss

STRONG_SHIFT = CameraShift(colour_gain=(1.35, 0.8, 0.65), brightness=30.0, contrast=0.7, noise_std=2.0,
                           yaw_deg=4.0)


@pytest.fixture(scope="module")
def pairs(tmp_path_factory):
    return generate_pairs(n=120, out=tmp_path_factory.mktemp("align") / "pairs", seed=1,
                          camera_shift=STRONG_SHIFT).out


@pytest.fixture(scope="module")
def aligned(tiny_run, pairs, tmp_path_factory):
    out = tmp_path_factory.mktemp("aligned") / "run"
    epochs: list = []
    report = align_encoder(policy_path=tiny_run, pairs_dir=pairs, out_dir=out, epochs=30, batch_size=64,
                           lr=1e-4, holdout=0.25, seed=0, threads=1, on_epoch=epochs.append)
    return report, epochs


def test_transfer_loss_is_half_the_squared_distance_averaged():
    sim = torch.tensor([[1.0, 2.0], [0.0, 0.0]])
    real = torch.tensor([[0.0, 0.0], [3.0, 4.0]])
    assert float(transfer_loss(sim, real)) == pytest.approx((0.5 * 5 + 0.5 * 25) / 2)


def test_alignment_lowers_the_heldout_latent_distance(aligned, pairs):
    report, epochs = aligned
    assert (report.pairs, report.heldout_pairs, report.train_pairs) == (120, 30, 90)
    assert report.heldout_distance_after < 0.7 * report.heldout_distance_before
    assert report.heldout_loss_after < report.heldout_loss_before
    assert [e.epoch for e in epochs] == list(range(1, 31)) and epochs[-1].epochs == 30
    assert epochs[-1].heldout_distance == pytest.approx(report.heldout_distance_after, rel=1e-5)
    assert epochs[-1].train_loss < epochs[0].train_loss


def test_the_heldout_figures_are_recomputable_from_the_written_policy(aligned, tiny_run, pairs):
    report, _ = aligned
    from sim2real import load_pairs

    data = load_pairs(pairs)
    order = np.random.default_rng(0).permutation(len(data))
    heldout = np.sort(order[:report.heldout_pairs])
    before, after = load_policy(tiny_run), load_policy(report.out_dir)
    target = before.encode(data.sim[heldout])
    distance_before = np.linalg.norm(before.encode(data.real[heldout]) - target, axis=1).mean()
    distance_after = np.linalg.norm(after.encode(data.real[heldout]) - target, axis=1).mean()
    assert distance_before == pytest.approx(report.heldout_distance_before, rel=1e-5)
    assert distance_after == pytest.approx(report.heldout_distance_after, rel=1e-5)


def test_actor_is_untouched_and_the_run_dir_is_complete(aligned, tiny_run):
    report, _ = aligned
    out = report.out_dir
    for name in ("config.yaml", "summary.json", "alignment.csv", "checkpoints/best.pt"):
        assert (out / name).is_file(), name
    source = load_checkpoint(tiny_run / "checkpoints" / "best.pt")["policy"]
    written = load_checkpoint(out / "checkpoints" / "best.pt")
    for key, value in source["actor"].items():
        assert torch.equal(value, written["policy"]["actor"][key]), key
    assert any(not torch.equal(v, written["policy"]["encoder"][k]) for k, v in source["encoder"].items())
    assert written["alignment"]["heldout_distance_after"] == pytest.approx(report.heldout_distance_after)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["aligned"] is True and summary["heldout_distance_before"] == report.heldout_distance_before
    with (out / "alignment.csv").open() as file:
        assert len(list(csv.DictReader(file))) == 30
    assert load_policy(out).act(np.zeros((2, 32, 64, 3), np.uint8)).shape == (2, 1)
    assert [p.name for p in out.parent.iterdir() if p.name.startswith(".")] == []


def test_bad_inputs_raise_and_write_nothing(tiny_run, pairs, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(PolicyLoadError):
        align_encoder(policy_path=tmp_path / "no-policy", pairs_dir=pairs, out_dir=out, epochs=1)
    with pytest.raises(FileNotFoundError):
        align_encoder(policy_path=tiny_run, pairs_dir=tmp_path / "no-pairs", out_dir=out, epochs=1)
    (tmp_path / "empty" / "sim").mkdir(parents=True)
    (tmp_path / "empty" / "real").mkdir()
    with pytest.raises(PairDataError, match="no image pairs"):
        align_encoder(policy_path=tiny_run, pairs_dir=tmp_path / "empty", out_dir=out, epochs=1)
    for bad in ({"epochs": 0}, {"batch_size": 0}, {"holdout": 1.0}, {"lr": -1.0}):
        with pytest.raises(AlignmentError):
            align_encoder(policy_path=tiny_run, pairs_dir=pairs, out_dir=out, **{"epochs": 1, **bad})
    single = generate_pairs(n=1, out=tmp_path / "single").out
    with pytest.raises(AlignmentError, match="too few"):
        align_encoder(policy_path=tiny_run, pairs_dir=single, out_dir=out, epochs=1)
    assert not out.exists()
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "keep.txt").write_text("mine")
    with pytest.raises(AlignmentError, match="not an empty folder"):
        align_encoder(policy_path=tiny_run, pairs_dir=pairs, out_dir=tmp_path / "busy", epochs=1)
    assert [p.name for p in (tmp_path / "busy").iterdir()] == ["keep.txt"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
