"""Plan speed: milliseconds per model-based decision with an aim (``dual.planner = progress``) against the
same plan without one (issue 50's step-cost question).

One decision of the aiming planner is, beside the plan both readings make (K = ``plan_steps`` normalised
gradient steps through the rollout's local models, `core.dual.planning.optimise_plan`), the start node's
action map (`LocalWorldModels.action_map`: one least-squares fit over the node's stored transitions, an
eigendecomposition of its d × d coupling) and the pull's term at every step (`RegionGoal.plan_term`). The
world is fed ``memory`` transitions of a made-up linear dynamics around one node (by default the model
memory's size, so the fit runs on as full a memory as training gives it: the node stores those not held out
for the reliability verdict), and both readings plan from the same rollout of depth
D_max. The figure is the median per decision in ms and the ratio aim / no aim, measured in the same run with
the two interleaved (this machine is noisy).

Run: ``python -m bench.plan_speed`` or ``dualsys bench plan --json``.
"""

from __future__ import annotations

import dataclasses
import json
import statistics
import time

import numpy as np
import torch

from core.config import load_config
from core.dual.planning import model_rollout, optimise_plan
from core.dual.readings import resolve
from core.dual.region_goal import RegionGoal
from core.dual.world_models import LocalWorldModels


def _world(latent_dim: int, action_dim: int,
           memory: int | None) -> tuple[LocalWorldModels, int, torch.Tensor]:
    """A world whose first node holds ``memory`` transitions of φ′ = φ + 0.05·A a + 0.01·noise."""
    dual = dataclasses.replace(load_config("default").dual, planner="progress")
    world = LocalWorldModels(dual, latent_dim, action_dim, generator=torch.Generator().manual_seed(0),
                             readings=resolve(dual))
    rng = np.random.default_rng(0)
    mixing = rng.normal(size=(latent_dim, action_dim))
    phi = torch.zeros(latent_dim)
    node = world.observe_state(phi)
    for _ in range(memory if memory is not None else world.memory_size):
        start = 0.01 * rng.normal(size=latent_dim)
        action = rng.uniform(-1.0, 1.0, size=action_dim)
        nxt = start + 0.05 * mixing @ action + 0.01 * rng.normal(size=latent_dim)
        world.learn_transition(node, torch.tensor(start, dtype=torch.float32),
                               torch.tensor(action, dtype=torch.float32), 0.0,
                               torch.tensor(nxt, dtype=torch.float32))
    return world, node, phi


def measure(latent_dim: int = 32, action_dim: int = 2, repeats: int = 200, memory: int | None = None) -> dict:
    """Median ms per decision without and with the aim, and their ratio."""
    if repeats < 1:
        raise ValueError("repeats must be >= 1")
    torch.set_num_threads(1)
    world, node, phi = _world(latent_dim, action_dim, memory)
    config = world.config
    generator = torch.Generator().manual_seed(1)

    def actor(latent: torch.Tensor) -> torch.Tensor:
        return torch.rand(latent.reshape(-1, latent_dim).shape[0], action_dim, generator=generator) * 2 - 1

    rollout = model_rollout(phi.reshape(1, -1), node, world.bank, actor, config.d_max,
                            continue_at=lambda _i, _n: True, locate=lambda _latent: node)
    planner = world.readings.planner
    centres = np.stack([np.zeros(latent_dim), np.ones(latent_dim)])

    def plain() -> None:
        optimise_plan(phi, rollout, world.bank, planner, steps=config.plan_steps, lr=config.plan_lr,
                      r_star=config.r_star)

    def aimed() -> None:
        goal = RegionGoal(centres, np.array([0.0, 1.0]), action_map=world.action_map(node))
        optimise_plan(phi, rollout, world.bank, planner, steps=config.plan_steps, lr=config.plan_lr,
                      r_star=config.r_star, aim=goal, aim_scale=config.intrinsic_scale)

    if world.action_map(node) is None:
        raise RuntimeError("the bench's node has no action map: too few stored transitions")
    samples: dict[str, list[float]] = {"no_aim": [], "aim": []}
    for _ in range(repeats):  # interleaved, so load from other processes affects both alike
        for name, run in (("no_aim", plain), ("aim", aimed)):
            start = time.perf_counter()
            run()
            samples[name].append(time.perf_counter() - start)
    ms = {name: round(1000.0 * statistics.median(times), 4) for name, times in samples.items()}
    return {"ms_per_decision": ms, "ratio_aim_to_no_aim": round(ms["aim"] / ms["no_aim"], 3),
            "latent_dim": latent_dim, "action_dim": action_dim, "horizon": rollout.depth,
            "plan_steps": config.plan_steps, "stored_transitions": world.stored_transitions(node),
            "repeats": repeats}


if __name__ == "__main__":
    print(json.dumps(measure()))
