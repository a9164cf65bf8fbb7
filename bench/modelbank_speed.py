"""World-model bank speed: predict + update time for 2, 50 and 500 nodes (goal: 500 ≤ 2× the cost of 2).

Each measurement draws a batch of (node, sample) pairs with node ids uniform over the live nodes and
times one `ModelBank.predict` plus one `ModelBank.update` (Eq. 5 with the stacked per-node Adam),
reporting the median over repeats in milliseconds. The work per call depends on the batch and the
number of distinct nodes it touches, not on how many nodes exist — that is the point of stacking.

Run: ``python -m bench.modelbank_speed`` or ``dualsys bench modelbank --json``.
"""

from __future__ import annotations

import json
import statistics
import time

import torch

from core.dual.model_bank import ModelBank

NODE_COUNTS = (2, 50, 500)


def _time_once(bank: ModelBank, batch: int, nodes: int, generator: torch.Generator) -> float:
    ids = torch.randint(0, nodes, (batch,), generator=generator)
    phi = torch.rand(batch, bank.latent_dim, generator=generator)
    action = torch.rand(batch, bank.action_dim, generator=generator) * 2 - 1
    next_phi = torch.rand(batch, bank.latent_dim, generator=generator)
    reward = torch.rand(batch, generator=generator) * 2 - 1
    start = time.perf_counter()
    bank.predict(ids, phi, action)
    bank.update(ids, phi, action, next_phi, reward)
    return time.perf_counter() - start


def measure(batch: int = 32, repeats: int = 200, latent_dim: int = 32, action_dim: int = 1) -> dict:
    """Median predict + update milliseconds per node count, and the 500-to-2 ratio."""
    if batch < 1 or repeats < 1:
        raise ValueError("batch and repeats must be >= 1")
    torch.set_num_threads(1)
    generator = torch.Generator().manual_seed(0)
    banks = {}
    for nodes in NODE_COUNTS:
        bank = ModelBank(latent_dim=latent_dim, action_dim=action_dim, initial_capacity=2,
                         generator=torch.Generator().manual_seed(nodes))
        bank.ensure_capacity(nodes)  # grows geometrically, as during training
        for _ in range(10):
            _time_once(bank, batch, nodes, generator)
        banks[nodes] = bank
    # Interleave the node counts so load from other processes affects all of them alike.
    samples: dict[int, list[float]] = {nodes: [] for nodes in NODE_COUNTS}
    for _ in range(repeats):
        for nodes, bank in banks.items():
            samples[nodes].append(_time_once(bank, batch, nodes, generator))
    ms = {str(nodes): round(1000.0 * statistics.median(times), 4) for nodes, times in samples.items()}
    return {
        "ms": ms,
        "ratio_500_to_2": round(ms["500"] / ms["2"], 3),
        "batch": batch,
        "repeats": repeats,
        "torch_threads": torch.get_num_threads(),
    }


if __name__ == "__main__":
    print(json.dumps(measure()))
