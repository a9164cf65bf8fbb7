"""Probe: what the imagined minibatch does to SAC+I2A's critic (Algorithm 3, lines 34-37), on one seed.

Runs one SAC+I2A cell with the settings of a finished grid cell (its ``config.yaml``) on another seed and
budget, and every ``--every`` updates writes one JSON line comparing the pixel minibatch with the imagined
one: how far the imagined latents leave the real minibatch's per-dimension range, the rewards the models
predict, the critic's values and TD targets on both, the mean TD error on both, and α. Grid 4
(reacher-hard) found SAC+I2A's critic diverging in both of its first reporting cells; this is how the
diagnosis on tuning seeds was made (docs/results.md, grid 4). It wraps the learner's update from outside,
so the run it observes is the same run as without it. A rerun on the same directory resumes.

    OMP_NUM_THREADS=1 python scripts/i2a_imagination_probe.py \
        results/study3-reacher-hard/SAC+I2A/task/seed-1/config.yaml --seed 101 --steps 100000 --out probe-101
    # the same with a candidate repair:   ... --set dual.imagination_depth=1 --out probe-101-depth1
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from core.config import load_config
from core.modelfree.learners import base
from core.modelfree.replay import LatentBatch, PixelBatch
from core.runs.trainer import train


def compare(learner: base.Learner, pixel: PixelBatch, latent: LatentBatch) -> dict[str, object]:
    """The pixel minibatch beside the imagined one (module docstring)."""
    with torch.no_grad():
        phi = learner.encoder(learner.encoder.prepare(pixel.obs))
        low, high = phi.min(0).values, phi.max(0).values
        margin = 0.25 * (high - low).clamp_min(1e-6)

        def outside(x: torch.Tensor) -> float:
            return float(((x < low - margin) | (x > high + margin)).any(1).float().mean())

        q_real = learner.q_value(phi, pixel.action)
        q_imagined = learner.q_value(latent.latent, latent.action)
        next_phi = learner.target_encoder(learner.encoder.prepare(pixel.next_obs))
        y_real = learner.td_target(pixel.reward, next_phi, pixel.terminated)
        y_imagined = learner.td_target(latent.reward, latent.next_latent, latent.done)
        return {
            "imagined": int(latent.latent.shape[0]),
            "latent_outside": outside(latent.latent),
            "next_latent_outside": outside(latent.next_latent),
            "abs_max": {"real": float(phi.abs().max()), "imagined": float(latent.latent.abs().max()),
                        "imagined_next": float(latent.next_latent.abs().max())},
            "reward": {"real": [float(pixel.reward.min()), float(pixel.reward.max())],
                       "imagined": [float(latent.reward.min()), float(latent.reward.max())]},
            "q_mean": {"real": float(q_real.mean()), "imagined": float(q_imagined.mean())},
            "q_abs_max": {"real": float(q_real.abs().max()), "imagined": float(q_imagined.abs().max())},
            "td_target_mean": {"real": float(y_real.mean()), "imagined": float(y_imagined.mean())},
            "td_error": {"real": float((q_real - y_real).abs().mean()),
                         "imagined": float((q_imagined - y_imagined).abs().mean())},
            "alpha": float(learner.alpha) if hasattr(learner, "alpha") else None,
        }


def summarise(path: Path, window: int = 10_000) -> list[dict[str, float]]:
    """A probe's records averaged over windows of ``window`` updates (the largest |Q|: the maximum)."""
    records = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    rows = []
    for start in range(0, max(r["update"] for r in records), window):
        part = [r for r in records if start < r["update"] <= start + window]
        if not part:
            continue

        def mean(key: str, side: str, part: list[dict] = part) -> float:
            return sum(r[key][side] for r in part) / len(part)

        rows.append({
            "updates": start + window,
            "q_mean_real": mean("q_mean", "real"), "q_mean_imagined": mean("q_mean", "imagined"),
            "q_abs_max_real": max(r["q_abs_max"]["real"] for r in part),
            "q_abs_max_imagined": max(r["q_abs_max"]["imagined"] for r in part),
            "td_error_real": mean("td_error", "real"), "td_error_imagined": mean("td_error", "imagined"),
            "next_latent_outside": sum(r["next_latent_outside"] for r in part) / len(part),
            "alpha_last": part[-1]["alpha"],
        })
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", type=Path, help="a grid cell's config.yaml (an I2A cell)")
    parser.add_argument("--seed", type=int, required=True, help="a tuning seed (>= 100)")
    parser.add_argument("--steps", type=int, required=True)
    parser.add_argument("--out", type=Path, required=True, help="run directory; its .jsonl sits beside it")
    parser.add_argument("--every", type=int, default=500, help="updates between two records")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="change one setting of the cell's config (repeatable; the config's own parsing)")
    parser.add_argument("--summary", action="store_true", help="print the .jsonl by 10k updates")
    args = parser.parse_args()
    if args.summary:
        for row in summarise(args.out.with_suffix(".jsonl")):
            print(json.dumps({key: round(value, 3) for key, value in row.items()}))
        return
    config = load_config("default", [f"run.seed={args.seed}", f"run.steps={args.steps}", *args.set],
                         file=args.config)
    records = args.out.with_suffix(".jsonl").open("a")
    update = base.Learner.update
    count = 0

    def observed(learner: base.Learner, pixel: PixelBatch,
                 latent: LatentBatch | None = None) -> dict[str, float]:
        nonlocal count
        count += 1
        if latent is not None and count % args.every == 0:
            record = {"update": learner.updates + 1, **compare(learner, pixel, latent)}
            records.write(json.dumps(record) + "\n")
            records.flush()
        return update(learner, pixel, latent)

    base.Learner.update = observed
    resume = (args.out / "checkpoints").exists()
    print(train(config, args.out, resume=resume, command="i2a imagination probe"))


if __name__ == "__main__":
    main()
