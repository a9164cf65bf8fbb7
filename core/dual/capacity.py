"""The growth rule of per-node storage (ITM nodes, world-model bank, learning progress, local buffers)."""

from __future__ import annotations


def grown_capacity(current: int, required: int) -> int:
    """The smallest ``current · 2^k`` (k ≥ 0) holding ``required`` slots: geometric growth, amortised O(1)."""
    capacity = max(1, current)
    while capacity < required:
        capacity *= 2
    return capacity
