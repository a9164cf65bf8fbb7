"""Held-out gain growth per region (core/dual/lagged_progress.py): what the progress planner aims at —
positive while a model learns what the action does, about 0 once it has converged and where the outcome is
noise, from the first scoring on."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from core.config import load_config
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels


def _world() -> LocalWorldModels:
    dual = load_config("default", ["dual.planner=progress", "dual.model_batch=1", "dual.model_memory=0"]).dual
    return LocalWorldModels(dual, 2, 1, regions=False, generator=torch.Generator().manual_seed(0),
                            readings=resolve(dual))


def _progress(world: LocalWorldModels, noise: float, steps: int, seed: int = 0, gain: float = 0.3,
              mean: float = 0.0) -> list[float]:
    """Progress of the one node after each step of a stream φ′ = φ + gain·a + mean (+ noise in φ′)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(steps):
        phi = rng.uniform(-1, 1, size=2)
        action = rng.uniform(-1, 1, size=1)
        nxt = phi + gain * action + mean + noise * rng.normal(size=2)
        as_tensor = lambda x: torch.tensor(x, dtype=torch.float32)  # noqa: E731
        world.learn_transition(0, as_tensor(phi), as_tensor(action), 0.0, as_tensor(nxt))
        out.append(float(world.lagged_progress.progress([0])[0]))
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


def test_noise_around_a_mean_the_action_does_not_move_scores_zero_from_the_first_scoring() -> None:
    """φ′ = φ + 0.5 + noise, the action irrelevant: the models learn the shift slowly (a real fall of their
    error, which the earlier readings took for progress), but the action-free least-squares predictor of the
    ring knows it already, so neither model ever gains on it and the progress stays 0 throughout; with the
    action driving the same shift, it does not."""
    noisy = _progress(_world(), noise=0.5, steps=1500, gain=0.0, mean=0.5)
    assert max(noisy) < 0.01
    driven = _progress(_world(), noise=0.0, steps=400, gain=0.3, mean=0.5)
    assert max(driven) > 0.05


def test_the_baseline_is_the_action_free_least_squares_fit() -> None:
    """e_base: [φ′, r] fitted on [φ, 1] — exact (0) for φ′ affine in φ, and the residual of the action's part
    otherwise."""
    world = _world()
    lp = world.lagged_progress
    rng = np.random.default_rng(1)
    phi = torch.tensor(rng.uniform(-1, 1, size=(40, 2)), dtype=torch.float32)
    action = torch.tensor(rng.uniform(-1, 1, size=(40, 1)), dtype=torch.float32)
    reward = torch.zeros(40)
    affine = phi @ torch.tensor([[0.5, 0.1], [-0.2, 0.9]]) + 0.3
    assert lp.baseline_error(phi, reward, affine) < 1e-6
    driven = affine + 0.3 * action
    inputs = np.hstack([phi.numpy(), np.ones((40, 1))]).astype(np.float64)
    coef, *_ = np.linalg.lstsq(inputs, driven.numpy().astype(np.float64), rcond=None)
    fitted = torch.tensor(inputs @ coef, dtype=torch.float32)
    expected = float(world.bank.errors(fitted, reward, driven, reward).mean())
    assert expected > 0.01
    assert lp.baseline_error(phi, reward, driven) == pytest.approx(expected, rel=1e-4)


def test_progress_survives_a_checkpoint() -> None:
    world = _world()
    _progress(world, noise=0.0, steps=100)
    clone = _world()
    clone.load_state_dict(world.state_dict())
    before, after = world.lagged_progress, clone.lagged_progress
    np.testing.assert_allclose(after.progress([0]), before.progress([0]))


def test_no_progress_before_the_node_holds_enough_held_out_transitions() -> None:
    """A node is scored on its held-out ring only once the ring holds MIN_HELD transitions (every
    ``HeldOut.every``-th transition goes there): before that its progress is 0 however fast it learns."""
    from core.dual.lagged_progress import MIN_HELD

    world = _world()
    every = world.heldout.every
    before = _progress(world, noise=0.0, steps=every * MIN_HELD - 1)
    assert max(before) == 0.0
    after = _progress(world, noise=0.0, steps=400)  # scored now: positive once the model beats the baseline
    assert max(after) > 0.0
