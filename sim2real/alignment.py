"""Sim-to-real encoder alignment (Section 4.2, Fig. 13): fine-tune f_ω so that f(s_real) ≈ f(s_sim).

    L_Transfer = ½ ‖φ_sim − φ_real‖²₂,   φ_sim = f_frozen(s_sim),  φ_real = f_ω(s_real)

over paired images of the same joint configuration and object position (the paper: 2 000 pairs, 200 epochs,
batch size 512). Decisions where the paper is silent:

* The target φ_sim comes from a **frozen copy** of the trained encoder, so the latent space the actor was
  trained on stays put and only the real images move into it; the loss is averaged over the batch.
* Only the encoder is trained (Adam, learning rate 1e-3 — the critic-autoencoder's rate); the actor μ is
  copied bit for bit, and the critic is not touched (it is not part of the deployed policy and is not
  carried into the aligned checkpoint, which holds encoder + actor like ``best.pt``).
* A held-out split (default 10 % of the pairs, chosen by ``seed``) is never trained on; the report gives its
  mean latent distance ‖φ_sim − φ_real‖₂ before and after, the mean |μ(φ_real) − μ(φ_sim)| of the actions,
  and how far the encoder moved on held-out *sim* images (``heldout_sim_drift``).
* The final epoch's weights are kept (no selection on the held-out split, so its figures stay unbiased).

Output: a new run directory (written to a hidden sibling folder, renamed at the end): ``config.yaml`` (the
source's config), ``checkpoints/best.pt`` (loadable by ``core.runs.policy.load_policy``, with an ``alignment``
record), ``summary.json`` (the figures) and ``alignment.csv`` (per-epoch train loss and held-out distance).
"""

from __future__ import annotations

import copy
import csv
import io
import json
import math
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from core.config import Config
from core.envs.spec import EnvSpec
from core.modelfree.networks import Encoder, to_float_chw
from core.runs.policy import load_policy, resolve_checkpoint
from core.runs.run_dir import CHECKPOINT_FORMAT, load_checkpoint
from sim2real.pair_dataset import PairDataError, load_pairs

ALIGN_LR = 1e-3


class AlignmentError(ValueError):
    """A user-caused alignment problem (bad option, too few pairs, output folder in use)."""


@dataclass(frozen=True)
class EpochRecord:
    epoch: int
    epochs: int
    train_loss: float
    """Mean L_Transfer over the epoch's training batches."""
    heldout_distance: float
    """Mean ‖φ_sim − φ_real‖₂ on the held-out pairs after the epoch."""


@dataclass(frozen=True)
class AlignmentReport:
    out_dir: Path
    source_checkpoint: Path
    pairs: int
    train_pairs: int
    heldout_pairs: int
    epochs: int
    batch_size: int
    lr: float
    seed: int
    heldout_distance_before: float
    heldout_distance_after: float
    heldout_loss_before: float
    heldout_loss_after: float
    heldout_action_diff_before: float
    heldout_action_diff_after: float
    heldout_sim_drift: float
    final_train_loss: float
    wall_s: float

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["out_dir"], data["source_checkpoint"] = str(self.out_dir), str(self.source_checkpoint)
        return data


@dataclass(frozen=True)
class _HeldOut:
    distance: float
    loss: float
    action_diff: float


def transfer_loss(phi_sim: torch.Tensor, phi_real: torch.Tensor) -> torch.Tensor:
    """L_Transfer = ½ ‖φ_sim − φ_real‖²₂ per pair, averaged over the batch (Section 4.2)."""
    return 0.5 * (phi_sim - phi_real).pow(2).sum(dim=1).mean()


def _latents(encoder: Encoder, images: np.ndarray, batch: int = 1024) -> torch.Tensor:
    with torch.no_grad():
        return torch.cat([encoder(to_float_chw(torch.from_numpy(images[i:i + batch])))
                          for i in range(0, len(images), batch)])


def _heldout(encoder: Encoder, actor: torch.nn.Module, real: np.ndarray, target: torch.Tensor,
             target_action: torch.Tensor) -> _HeldOut:
    phi_real = _latents(encoder, real)
    with torch.no_grad():
        action = actor(phi_real)
    return _HeldOut(distance=float((phi_real - target).norm(dim=1).mean()),
                    loss=float(transfer_loss(target, phi_real)),
                    action_diff=float((action - target_action).abs().mean()))


def _check_options(epochs: int, batch_size: int, lr: float, holdout: float) -> None:
    if epochs < 1:
        raise AlignmentError(f"--epochs must be >= 1, got {epochs}")
    if batch_size < 1:
        raise AlignmentError(f"--batch-size must be >= 1, got {batch_size}")
    if not (lr > 0 and math.isfinite(lr)):
        raise AlignmentError(f"the learning rate must be > 0, got {lr}")
    if not 0.0 < holdout < 1.0:
        raise AlignmentError(f"--holdout must lie strictly between 0 and 1, got {holdout}")


def _check_out(out_dir: Path) -> None:
    if out_dir.exists() and (not out_dir.is_dir() or any(out_dir.iterdir())):
        raise AlignmentError(f"{out_dir} already exists and is not an empty folder")


def align_encoder(
    *,
    policy_path: Path | str,
    pairs_dir: Path | str,
    out_dir: Path | str,
    epochs: int = 200,
    batch_size: int = 512,
    lr: float = ALIGN_LR,
    holdout: float = 0.1,
    seed: int = 0,
    threads: int | None = None,
    command: str | None = None,
    on_epoch: Callable[[EpochRecord], None] | None = None,
) -> AlignmentReport:
    """Align the encoder of ``policy_path`` on ``pairs_dir``; write the aligned policy to ``out_dir``."""
    started = time.perf_counter()
    out_dir = Path(out_dir)
    _check_options(epochs, batch_size, lr, holdout)
    _check_out(out_dir)
    pairs = load_pairs(pairs_dir)
    checkpoint_path = resolve_checkpoint(policy_path)
    policy = load_policy(checkpoint_path)
    source = load_checkpoint(checkpoint_path)
    if pairs.sim.shape[1:] != tuple(policy.obs_shape):
        raise PairDataError(f"the pairs are {list(pairs.sim.shape[1:])} images but the policy takes "
                            f"{list(policy.obs_shape)}")
    heldout_count = max(1, round(holdout * len(pairs)))
    if len(pairs) - heldout_count < 1:
        raise AlignmentError(f"{len(pairs)} pair(s) are too few for a held-out split of {holdout:g}; "
                             "give at least 2 pairs")
    if threads is not None:
        torch.set_num_threads(max(1, int(threads)))
    torch.manual_seed(seed)
    order = np.random.default_rng(seed).permutation(len(pairs))
    heldout_idx, train_idx = np.sort(order[:heldout_count]), order[heldout_count:]

    encoder = copy.deepcopy(policy.encoder)
    frozen = copy.deepcopy(policy.encoder).eval().requires_grad_(False)
    actor = policy.actor.eval().requires_grad_(False)
    train_real = np.ascontiguousarray(pairs.real[train_idx])
    train_target = _latents(frozen, np.ascontiguousarray(pairs.sim[train_idx]))
    heldout_real = np.ascontiguousarray(pairs.real[heldout_idx])
    heldout_sim = np.ascontiguousarray(pairs.sim[heldout_idx])
    heldout_target = _latents(frozen, heldout_sim)
    with torch.no_grad():
        heldout_target_action = actor(heldout_target)
    before = _heldout(encoder, actor, heldout_real, heldout_target, heldout_target_action)

    optimiser = torch.optim.Adam(encoder.parameters(), lr=lr)
    generator = torch.Generator().manual_seed(seed)
    history: list[EpochRecord] = []
    encoder.train()
    for epoch in range(1, epochs + 1):
        permutation = torch.randperm(len(train_idx), generator=generator).numpy()
        losses = []
        for start in range(0, len(permutation), batch_size):
            batch = permutation[start:start + batch_size]
            phi_real = encoder(to_float_chw(torch.from_numpy(train_real[batch])))
            loss = transfer_loss(train_target[batch], phi_real)
            optimiser.zero_grad(set_to_none=True)
            loss.backward()
            optimiser.step()
            losses.append(float(loss.detach()) * len(batch))
        distance = _heldout(encoder, actor, heldout_real, heldout_target, heldout_target_action).distance
        record = EpochRecord(epoch, epochs, sum(losses) / len(permutation), distance)
        history.append(record)
        if on_epoch is not None:
            on_epoch(record)
    encoder.eval()
    after = _heldout(encoder, actor, heldout_real, heldout_target, heldout_target_action)
    drift = float((_latents(encoder, heldout_sim) - heldout_target).norm(dim=1).mean())

    report = AlignmentReport(
        out_dir=out_dir, source_checkpoint=checkpoint_path, pairs=len(pairs), train_pairs=len(train_idx),
        heldout_pairs=heldout_count, epochs=epochs, batch_size=batch_size, lr=lr, seed=seed,
        heldout_distance_before=before.distance, heldout_distance_after=after.distance,
        heldout_loss_before=before.loss, heldout_loss_after=after.loss,
        heldout_action_diff_before=before.action_diff, heldout_action_diff_after=after.action_diff,
        heldout_sim_drift=drift, final_train_loss=history[-1].train_loss,
        wall_s=time.perf_counter() - started,
    )
    _write_run_dir(out_dir, source, policy.config, encoder, actor, report, history, Path(pairs_dir), command)
    return report


def _write_run_dir(out_dir: Path, source: dict[str, Any], config: Config, encoder: Encoder,
                   actor: torch.nn.Module, report: AlignmentReport, history: list[EpochRecord],
                   pairs_dir: Path, command: str | None) -> None:
    """Write the aligned run directory via a hidden sibling folder and one rename."""
    summary = {**report.to_dict(), "aligned": True, "pairs_dir": str(pairs_dir.resolve()),
               "source_eval": source.get("eval", {})}
    checkpoint = {
        "format": CHECKPOINT_FORMAT,
        "config": config.to_dict(),
        **EnvSpec.from_dict({**source, "action_dim": actor.action_dim}).to_dict(),
        "counters": source.get("counters", {}),
        "eval": source.get("eval", {}),
        "policy": {
            "encoder": encoder.state_dict(),
            "actor": actor.state_dict(),
            **{key: value for key, value in source.get("policy", {}).items() if key == "bounds"},
        },
        "alignment": json.loads(json.dumps(summary, default=str)),
    }
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.", suffix=".tmp", dir=out_dir.parent))
    try:
        (staging / "checkpoints").mkdir()
        torch.save(checkpoint, staging / "checkpoints" / "best.pt")
        (staging / "config.yaml").write_text(config.to_yaml())
        (staging / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
        table = io.StringIO()
        writer = csv.writer(table)
        writer.writerow(["epoch", "train_loss", "heldout_distance"])
        writer.writerows([r.epoch, r.train_loss, r.heldout_distance] for r in history)
        (staging / "alignment.csv").write_text(table.getvalue())
        if command:
            (staging / "command.txt").write_text(command.rstrip("\n") + "\n")
        _check_out(out_dir)
        if out_dir.exists():
            out_dir.rmdir()
        staging.chmod(0o755)
        os.replace(staging, out_dir)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
