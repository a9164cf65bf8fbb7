"""Check: the local world models beat "nothing changes" (Eq. 5, Eq. 8; ``dual.world_models``,
``dual.model_batch``, ``dual.model_memory``).

Purpose (Section 2.2): M_n and R_n predict φ′ and r well enough to plan and imagine with. The least a model
must do is beat the trivial predictor φ̂′ = φ, r̂ = 0 — in issue #19's grasp runs the literal models' error was
1.3–3.5× that predictor's. The check streams a stationary latent stream through `LocalWorldModels` exactly
as the agents do (``observe_state`` then ``learn_transition`` per real step) and reports the mean Eq. 8 error
of the models' predictions of new transitions, before each is learnt from, divided by the no-change
predictor's error on the same transitions, over the last quarter of the stream.

`known_dynamics` is the command's stream: a small known dynamics, φ ∈ R^8, a ∈ [−1, 1]²,
φ′ = φ + 0.1·tanh(A φ + B a) − 0.02 φ + 0.005 ε, r = 0.5·tanh(u·φ′), with uniform random actions. The test
suite also runs `error_ratio` on the latents of NicoGrasp observations from a frozen encoder.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
import torch

from core.config import DualConfig
from core.dual.readings import Readings, resolve
from core.dual.world_models import LocalWorldModels

Transition = tuple[np.ndarray, np.ndarray, float, np.ndarray]
"""(φ, a, r, φ′) of a latent stream."""


def known_dynamics(steps: int, seed: int, dim: int = 8, actions: int = 2) -> Iterator[Transition]:
    """The stationary stream of the module docstring."""
    rng = np.random.default_rng(seed)
    a_mat = rng.normal(size=(dim, dim)) / np.sqrt(dim)
    b_mat = rng.normal(size=(dim, actions))
    u = rng.normal(size=dim) / np.sqrt(dim)
    phi = rng.normal(size=dim)
    for _ in range(steps):
        action = rng.uniform(-1.0, 1.0, size=actions)
        nxt = phi + 0.1 * np.tanh(a_mat @ phi + b_mat @ action) - 0.02 * phi + 0.005 * rng.normal(size=dim)
        yield phi, action, float(0.5 * np.tanh(u @ nxt)), nxt
        phi = nxt


def error_ratio(dual: DualConfig, stream: Iterable[Transition], latent_dim: int, action_dim: int,
                seed: int = 0, readings: Readings | None = None) -> float:
    """Mean Eq. 8 error of the models / of "nothing changes" on the last quarter of ``stream`` (``readings``:
    those instead of ``dual``'s)."""
    world = LocalWorldModels(dual, latent_dim, action_dim, generator=torch.Generator().manual_seed(seed),
                             readings=resolve(dual) if readings is None else readings)
    errors, no_change = [], []
    for phi, action, reward, nxt in stream:
        phi_t = torch.as_tensor(phi, dtype=torch.float32)
        next_t = torch.as_tensor(nxt, dtype=torch.float32)
        node = world.observe_state(phi_t)
        feedback = world.learn_transition(node, phi_t, torch.as_tensor(action, dtype=torch.float32), reward,
                                          next_t)
        errors.append(feedback.error)
        no_change.append(float(world.bank.errors(phi_t[None], torch.zeros(1), next_t[None],
                                                 torch.tensor([reward]))[0]))
    quarter = max(1, len(errors) // 4)
    return float(np.mean(errors[-quarter:]) / np.mean(no_change[-quarter:]))


def world_model_check(dual: DualConfig, steps: int = 3000, seeds: int = 2) -> dict[str, float]:
    """The JSON figure: the error ratio on `known_dynamics` (mean over seeds)."""
    ratios = [error_ratio(dual, known_dynamics(steps, seed), 8, 2, seed) for seed in range(seeds)]
    return {"error_ratio_to_no_change": round(float(np.mean(ratios)), 3)}
