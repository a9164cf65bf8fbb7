"""A node's linear latent dynamics, through which an aiming plan predicts where it goes (issue 50).

The aiming planners (`core.dual.region_goal.RegionGoal.plan_term`) pull a plan toward a goal on the map at the
latents the plan is predicted to reach. The prediction is a least-squares fit over the start node's stored
real transitions (`fit_action_map`),

    Δφ ≈ B·a + D·(φ − φ̄) + c,

its coefficients kept where they are significant (|t| ≥ `MOVED_T`: a direction that changes at random gets
no spurious tilt, nor one along which the node's states hardly vary a spurious D), restricted by Q = K Kᵀ to
the directions the latent carries from step to step (K the eigenvectors of the symmetric part of I + D with
eigenvalue ≥ `PERSISTENT`: a position or a velocity, not a screen whose next value does not depend on its
last), and rolled over the plan (`ActionMap.rollout`):

    φ̃_{h+1} = φ̃_h + Q·(B â_h + D·(φ̃_h − φ̄) + c) = M φ̃_h + Q B â_h + Q (c − D φ̄),   M = I + Q D.

Why the coupling D and the drift c (docs/dual-system.md, item 16): with B alone, φ̃_{h+1} = φ + Σ B â_i, a goal
reached only through a coupling gets no pull — on MountainCar the action moves the velocity and the velocity
moves the position, so B's position row is 0 and a goal at a position (the regions of largest progress up
the hill) pulled only toward its node's velocity. Why Q: on the controlled check a goal's screen value, which
no plan can keep, outweighed the pull toward its position (item 11). Outside K, φ̃ keeps φ's value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

MOVED_T = 3.0
"""Least |t| of a fitted coefficient that counts (`fit_action_map`)."""

PERSISTENT = 0.5
"""Least eigenvalue of the symmetric part of ∂φ′/∂φ along which a latent direction counts as carried from one
step to the next (`fit_action_map`): 1 for a position, 0 for a screen that shows a new value every step."""


@dataclass(frozen=True)
class ActionMap:
    """φ̃_{h+1} = ``carries`` φ̃_h + ``moves`` â_h + ``drift`` (module docstring)."""

    moves: np.ndarray
    """Q B ``[d, action]``: how an action moves the latent."""
    carries: np.ndarray
    """M = I + Q D ``[d, d]``: how the latent carries itself into the next step."""
    drift: np.ndarray
    """Q (c − D φ̄) ``[d]``: the change with no action."""

    def rollout(self, phi: np.ndarray, plan: np.ndarray) -> np.ndarray:
        """φ̃_1 … φ̃_H ``[H, d]`` of the plan ``[H, action]`` from ``phi`` ``[d]``."""
        latents = np.empty((plan.shape[0], self.carries.shape[0]))
        current = np.asarray(phi, dtype=np.float64).reshape(-1)
        pushed = plan @ self.moves.T + self.drift  # Q B â_h + Q (c − D φ̄), every h at once
        for h in range(plan.shape[0]):
            current = self.carries @ current + pushed[h]
            latents[h] = current
        return latents

    def pull_back(self, grads: np.ndarray) -> np.ndarray:
        """The gradient w.r.t. the plan ``[H, action]`` of Σ_h f(φ̃_{h+1}) from ∇f at each φ̃_{h+1} (``grads``
        ``[H, d]``): ∂/∂â_i = (Q B)ᵀ λ_i with λ_i = ∇f(φ̃_{i+1}) + Mᵀ λ_{i+1} (the adjoint, back from H)."""
        adjoint = np.zeros(grads.shape[1])
        out = np.empty((grads.shape[0], self.moves.shape[1]))
        for h in reversed(range(grads.shape[0])):
            adjoint = grads[h] + self.carries.T @ adjoint
            out[h] = adjoint @ self.moves
        return out


def fit_action_map(latent: torch.Tensor, action: torch.Tensor, next_latent: torch.Tensor) -> ActionMap | None:
    """The node's `ActionMap` from its stored transitions (φ ``[N, d]``, a ``[N, action]``, φ′ ``[N, d]``):
    the least-squares fit of the module docstring, significant coefficients only, restricted to the carried
    directions. None with fewer than 4·(|a| + d + 1) transitions or when no action moves a carried
    direction."""
    (count, dim), actions = latent.shape, action.shape[1]
    if count < 4 * (actions + dim + 1):
        return None
    states = latent.double().numpy()
    mean = states.mean(axis=0)
    inputs = np.c_[action.double().numpy(), states - mean, np.ones(count)]
    change = next_latent.double().numpy() - states
    coef = np.linalg.lstsq(inputs, change, rcond=None)[0]  # [action + d + 1, d]
    residual = ((change - inputs @ coef) ** 2).sum(axis=0) / (count - inputs.shape[1])  # σ² per direction
    inverse = np.diag(np.linalg.pinv(inputs.T @ inputs))  # (XᵀX)⁻¹_jj per input
    error = np.sqrt(np.maximum(residual[None, :] * inverse[:, None], 1e-30))
    significant = np.where(np.abs(coef) >= MOVED_T * error, coef, 0.0)
    moved = significant[:actions].T  # B [d, action]
    coupling = significant[actions:actions + dim].T  # D [d, d]
    offset = significant[-1]  # c [d]
    eigenvalues, eigenvectors = np.linalg.eigh(0.5 * (2.0 * np.eye(dim) + coupling + coupling.T))
    kept = eigenvectors[:, eigenvalues >= PERSISTENT]
    carried = kept @ kept.T  # Q
    moves = carried @ moved
    if not moves.any():
        return None
    return ActionMap(moves=moves, carries=np.eye(dim) + carried @ coupling,
                     drift=carried @ (offset - coupling @ mean))
