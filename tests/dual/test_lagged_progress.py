"""Fractional held-out progress per region (core/dual/lagged_progress.py): what the progress planner aims at —
positive while a model improves, about 0 once it has converged and where the outcome is noise."""

from __future__ import annotations

import numpy as np
import torch

from core.config import load_config
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels


def _world() -> LocalWorldModels:
    dual = load_config("default", ["dual.planner=progress", "dual.model_batch=1", "dual.model_memory=0"]).dual
    return LocalWorldModels(dual, 2, 1, regions=False, generator=torch.Generator().manual_seed(0),
                            readings=resolve(dual))


def _progress(world: LocalWorldModels, noise: float, steps: int, seed: int = 0) -> list[float]:
    """Relative progress of the one node after each step of a stream φ′ = φ + 0.3·a (+ noise in φ′)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(steps):
        phi = rng.uniform(-1, 1, size=2)
        action = rng.uniform(-1, 1, size=1)
        nxt = phi + 0.3 * action + noise * rng.normal(size=2)
        as_tensor = lambda x: torch.tensor(x, dtype=torch.float32)  # noqa: E731
        world.learn_transition(0, as_tensor(phi), as_tensor(action), 0.0, as_tensor(nxt))
        out.append(float(world.lagged_progress.relative([0])[0]))
    return out


def test_progress_is_positive_while_learning_and_fades_once_learnt() -> None:
    progress = _progress(_world(), noise=0.0, steps=3000)
    early, late = np.mean(progress[50:400]), np.mean(progress[-500:])
    assert early > 0.05
    assert late < 0.25 * early


def test_progress_of_pure_noise_stays_near_zero() -> None:
    """Outcomes that are noise around a learnable mean: once the mean is learnt, the paired difference of the
    lagged and current models has mean about 0 however large the noise."""
    learnable = np.mean(_progress(_world(), noise=0.0, steps=400)[50:])
    noisy = _progress(_world(), noise=1.0, steps=3000)
    assert np.mean(noisy[-1000:]) < 0.25 * learnable


def test_progress_survives_a_checkpoint() -> None:
    world = _world()
    _progress(world, noise=0.0, steps=100)
    clone = _world()
    clone.load_state_dict(world.state_dict())
    before, after = world.lagged_progress, clone.lagged_progress
    np.testing.assert_allclose(after.relative([0]), before.relative([0]))


def test_no_progress_before_the_node_holds_enough_held_out_transitions() -> None:
    """A node is scored on its held-out ring only once the ring holds MIN_HELD transitions (every
    ``HeldOut.every``-th transition goes there): before that its progress is 0 however fast it learns."""
    from core.dual.lagged_progress import MIN_HELD

    world = _world()
    every = world.heldout.every
    before = _progress(world, noise=0.0, steps=every * MIN_HELD - 1)
    assert max(before) == 0.0
    after = _progress(world, noise=0.0, steps=every * 4)
    assert max(after) > 0.0
