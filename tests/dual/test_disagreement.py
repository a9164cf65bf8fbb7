"""Per-region ensemble disagreement (core/dual/disagreement.py): what the disagreement planner aims at —
large where the region's models have not learnt yet, shrinking as they learn, and small where the outcome is
noise (the members agree on its mean)."""

from __future__ import annotations

import numpy as np
import torch

from core.config import load_config
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels


def _world() -> LocalWorldModels:
    dual = load_config("default", ["dual.planner=disagreement"]).dual
    return LocalWorldModels(dual, 2, 1, regions=False, generator=torch.Generator().manual_seed(0),
                            readings=resolve(dual))


def _disagreement(world: LocalWorldModels, noise: float, steps: int, seed: int = 0) -> list[float]:
    rng = np.random.default_rng(seed)
    as_tensor = lambda x: torch.tensor(x, dtype=torch.float32)  # noqa: E731
    out = []
    for _ in range(steps):
        phi = rng.uniform(-1, 1, size=2)
        action = rng.uniform(-1, 1, size=1)
        nxt = phi + 0.3 * action + noise * rng.normal(size=2)
        world.learn_transition(0, as_tensor(phi), as_tensor(action), 0.0, as_tensor(nxt))
        out.append(float(world.disagreement.value[0]))
    return out


def test_disagreement_shrinks_as_the_members_learn_and_stays_small_under_noise() -> None:
    learnt = _disagreement(_world(), noise=0.0, steps=1500)
    assert np.mean(learnt[-200:]) < 0.3 * np.mean(learnt[:50])
    noisy = _disagreement(_world(), noise=1.0, steps=1500)
    assert np.mean(noisy[-200:]) < 0.3 * np.mean(noisy[:50])


def test_the_members_are_one_batched_bank_and_survive_a_checkpoint() -> None:
    world = _world()
    _disagreement(world, noise=0.0, steps=30)
    assert world.disagreement.bank.theta.shape[0] >= world.bank.theta.shape[0] * world.disagreement.members
    clone = _world()
    clone.load_state_dict(world.state_dict())
    np.testing.assert_allclose(clone.disagreement.value, world.disagreement.value)
    torch.testing.assert_close(clone.disagreement.bank.theta, world.disagreement.bank.theta)
