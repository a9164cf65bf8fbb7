"""Exploration noise of the deterministic learners (DDPG, CACLA, TD3): Algorithm 2, line 20.

Both act in the agents' normalised action space [-1, 1] (so σ is σ/2 of each dimension's range in the env's
units, ``core.envs.spec``) and draw from the agent's seeded NumPy generator. σ decays linearly from
``agent.noise_std`` to ``agent.noise_final_std`` over ``agent.noise_anneal_steps`` training steps (the
``paper`` profile keeps σ = 1).

* :class:`GaussianNoise` — a ← clip(a + N(0, σ²), −1, 1), i.i.d. per step (the paper).
* :class:`OrnsteinUhlenbeckNoise` — a ← clip(a + x_t, −1, 1) with x_{t+1} = x_t + θ (0 − x_t) dt + σ √dt ε,
  dt = 0.01, x reset to 0 every episode: temporally correlated noise (Lillicrap et al. 2016; SB3's
  ``OrnsteinUhlenbeckActionNoise``, which the zoo's MountainCar DDPG uses).

During the uniform warm-up (``agent.warmup = uniform``, the first ``learning_starts`` steps) the noise
perturbs the uniform action as it would the actor's, a ← clip(u + noise, −1, 1), so its process runs from the
first step: SB3's ``OffPolicyAlgorithm._sample_action`` does exactly this. It matters: with the
Ornstein-Uhlenbeck noise, a process that starts only after the warm-up found MountainCarContinuous' flag
within 2 000 steps in 0 of 6 seeds, against 3 of 8 with SB3's order and 4 of 7 for SB3 itself
(docs/results.md, issue 28).
"""

from __future__ import annotations

import numpy as np

from core.config import AgentConfig


class GaussianNoise:
    """i.i.d. Gaussian noise with a linearly annealed σ (module docstring)."""

    def __init__(self, std: float, final_std: float, anneal_steps: int) -> None:
        self.std, self.final_std, self.anneal_steps = std, final_std, max(1, anneal_steps)

    def std_at(self, step: int) -> float:
        fraction = min(1.0, step / self.anneal_steps)
        return self.std + fraction * (self.final_std - self.std)

    def reset(self) -> None:
        """Nothing to reset: the draws are independent."""

    def perturb(self, action: np.ndarray, step: int, rng: np.random.Generator) -> np.ndarray:
        noisy = action + rng.normal(0.0, self.std_at(step), size=action.shape)
        return np.clip(noisy, -1.0, 1.0).astype(np.float32)

    def state(self) -> list[float]:
        return []

    def load_state(self, state: list[float]) -> None:
        return None


class OrnsteinUhlenbeckNoise(GaussianNoise):
    """Ornstein-Uhlenbeck noise around 0 with an annealed σ (module docstring)."""

    DT = 1e-2
    """SB3's default time step."""

    def __init__(
        self, std: float, final_std: float, anneal_steps: int, theta: float, action_dim: int
    ) -> None:
        super().__init__(std, final_std, anneal_steps)
        self.theta = theta
        self.x = np.zeros(action_dim)

    def reset(self) -> None:
        self.x = np.zeros_like(self.x)

    def perturb(self, action: np.ndarray, step: int, rng: np.random.Generator) -> np.ndarray:
        sigma = self.std_at(step)
        step = rng.normal(size=self.x.shape)
        self.x = self.x - self.theta * self.x * self.DT + sigma * np.sqrt(self.DT) * step
        return np.clip(action + self.x, -1.0, 1.0).astype(np.float32)

    def state(self) -> list[float]:
        return [float(v) for v in self.x]

    def load_state(self, state: list[float]) -> None:
        if state:
            self.x = np.asarray(state, dtype=np.float64)


def make_noise(agent: AgentConfig, action_dim: int) -> GaussianNoise:
    """The exploration noise ``agent.noise`` names."""
    if agent.noise == "ou":
        return OrnsteinUhlenbeckNoise(agent.noise_std, agent.noise_final_std, agent.noise_anneal_steps,
                                      agent.noise_theta, action_dim)
    return GaussianNoise(agent.noise_std, agent.noise_final_std, agent.noise_anneal_steps)


def uniform_warmup(
    agent: AgentConfig, step: int, action_dim: int, rng: np.random.Generator
) -> np.ndarray | None:
    """A uniform random action before ``learning_starts`` when ``agent.warmup = uniform`` (SB3), else None.
    The noise-exploring learners perturb it with their noise, as SB3 does (module docstring)."""
    if agent.warmup != "uniform" or step >= agent.learning_starts:
        return None
    return rng.uniform(-1.0, 1.0, size=action_dim).astype(np.float32)
