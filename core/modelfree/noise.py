"""Exploration noise of the deterministic learners (DDPG, CACLA, TD3): Algorithm 2, line 20.

Both act in the agents' normalised action space [-1, 1] (so σ is σ/2 of each dimension's range in the env's
units, ``core.envs.spec``) and draw from the agent's seeded NumPy generator. σ decays linearly from
``agent.noise_std`` to ``agent.noise_final_std`` over ``agent.noise_anneal_steps`` training steps (the
``paper`` profile keeps σ = 1).

* :class:`GaussianNoise` — a ← clip(a + N(0, σ²), −1, 1), i.i.d. per step (the paper).
* :class:`OrnsteinUhlenbeckNoise` — a ← clip(a + x_t, −1, 1) with x_{t+1} = x_t + θ (0 − x_t) dt + σ √dt ε,
  dt = 0.01, x reset to 0 every episode: temporally correlated noise (Lillicrap et al. 2016; SB3's
  ``OrnsteinUhlenbeckActionNoise``, which the zoo's MountainCar DDPG uses).
* :class:`PinkNoise` — a ← clip(a + σ x_t, −1, 1) with x_t the package ``pink-noise-rl``'s
  ``PinkNoiseProcess`` (Eberhard et al., "Pink Noise Is All You Need", ICLR 2023): one unit-variance 1/f
  sequence per action dimension, ``agent.noise_seq_len`` steps long (the episode length), drawn afresh at
  every episode start from the run's generator. SAC uses the same process for ε of its sample instead
  (``core.modelfree.learners.sac``).

During the uniform warm-up (``agent.warmup = uniform``, the first ``learning_starts`` steps) the noise
perturbs the uniform action as it would the actor's, a ← clip(u + noise, −1, 1), so its process runs from the
first step: SB3's ``OffPolicyAlgorithm._sample_action`` does exactly this. It matters: with the
Ornstein-Uhlenbeck noise, a process that starts only after the warm-up found MountainCarContinuous' flag
within 2 000 steps in 0 of 6 seeds, against 3 of 8 with SB3's order and 4 of 7 for SB3 itself
(docs/results.md, issue 28).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from core.config import AgentConfig, Config


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


class PinkNoise(GaussianNoise):
    """Pink noise from the package ``pink-noise-rl`` with an annealed σ (module docstring).

    The package's process takes its generator when built and draws a whole sequence there and at every
    ``reset()``. The learner sees the run's generator only when it acts, so each episode's sequence is drawn
    at the episode's first draw: the process is built then with that generator (first episode), or reset
    (every later one, ``reset()`` at the episode start marks it due). A resumed run draws at the same moment.
    A sequence shorter than the episode is followed by a fresh one (the package's buffer)."""

    def __init__(
        self, std: float, final_std: float, anneal_steps: int, seq_len: int, action_dim: int
    ) -> None:
        super().__init__(std, final_std, anneal_steps)
        self.seq_len, self.action_dim = int(seq_len), int(action_dim)
        self.process: Any = None
        """``pink.PinkNoiseProcess`` of size ``(action_dim, seq_len)``, built at the first draw."""
        self.fresh = False
        """A new episode began: its first draw resets the process (a new sequence)."""
        self.pending: list[float] = []
        """A loaded sequence and position, put back when the process is built (its generator: the run's)."""

    def sample(self, rng: np.random.Generator) -> np.ndarray:
        """The process's next value ``[action_dim]`` (unit variance)."""
        if self.process is None:
            self.process = make_pink_process(self.action_dim, self.seq_len, rng, state=self.pending)
            if self.pending and self.fresh:
                self.process.reset()
            self.pending = []
        elif self.fresh:
            self.process.reset()
        self.fresh = False
        return np.asarray(self.process.sample(), dtype=np.float64).reshape(self.action_dim)

    def reset(self) -> None:
        self.fresh = True

    def perturb(self, action: np.ndarray, step: int, rng: np.random.Generator) -> np.ndarray:
        noisy = action + self.std_at(step) * self.sample(rng)
        return np.clip(noisy, -1.0, 1.0).astype(np.float32)

    def state(self) -> list[float]:
        """``[fresh, idx, *sequence]`` (``[fresh]`` before the first draw)."""
        sequence = pink_state(self.process) if self.process is not None else self.pending
        return [float(self.fresh), *sequence]

    def load_state(self, state: list[float]) -> None:
        self.process = None
        self.fresh = bool(state[0]) if state else False
        self.pending = [float(v) for v in state[1:]]


def make_pink_process(
    action_dim: int, seq_len: int, rng: np.random.Generator, state: list[float] | None = None
) -> Any:
    """The package's ``PinkNoiseProcess(size=(action_dim, seq_len), rng=rng)``; with a saved ``state``
    (:func:`pink_state`) its sequence and position are put back without a draw from ``rng``."""
    from pink import PinkNoiseProcess

    if not state:
        return PinkNoiseProcess(size=(action_dim, seq_len), rng=rng)
    process = PinkNoiseProcess(size=(action_dim, seq_len), rng=np.random.default_rng(0))
    process.rng = rng
    process.idx = int(state[0])
    process.buffer = np.asarray(state[1:], dtype=np.float64).reshape(action_dim, seq_len)
    return process


def pink_state(process: Any) -> list[float]:
    """A pink process's position and current sequence as floats: ``[idx, *buffer.ravel()]``."""
    return [float(process.idx), *(float(v) for v in np.asarray(process.buffer).ravel())]


def episode_limit(env: Any) -> int | None:
    """The step limit of a built env: gymnasium's ``max_episode_steps`` (the ``TimeLimit``), else the env's
    own ``max_steps`` (NicoGrasp, the dualsys ids), else None."""
    spec = getattr(env, "spec", None)
    limit = getattr(spec, "max_episode_steps", None)
    if limit is None:
        limit = getattr(getattr(env, "unwrapped", env), "max_steps", None)
    return None if limit is None else int(limit)


DEFAULT_SEQ_LEN = 1000
"""Pink noise's sequence length on an env with no step limit."""


def resolve_noise(config: Config) -> AgentConfig:
    """``config.agent`` with ``noise_seq_len`` filled in for pink noise (None: the env's step limit, read
    from the env ``config.env`` builds; :data:`DEFAULT_SEQ_LEN` without one); unchanged otherwise."""
    agent = config.agent
    if agent.noise != "pink" or agent.noise_seq_len is not None:
        return agent
    from core.envs.gym_env import make_env

    env = make_env(config.env).env
    try:
        limit = episode_limit(env)
    finally:
        env.close()
    return dataclasses.replace(agent, noise_seq_len=limit or DEFAULT_SEQ_LEN)


def make_noise(agent: AgentConfig, action_dim: int) -> GaussianNoise:
    """The exploration noise ``agent.noise`` names."""
    if agent.noise == "pink":
        return PinkNoise(agent.noise_std, agent.noise_final_std, agent.noise_anneal_steps,
                         pink_seq_len(agent), action_dim)
    if agent.noise == "ou":
        return OrnsteinUhlenbeckNoise(agent.noise_std, agent.noise_final_std, agent.noise_anneal_steps,
                                      agent.noise_theta, action_dim)
    return GaussianNoise(agent.noise_std, agent.noise_final_std, agent.noise_anneal_steps)


def pink_seq_len(agent: AgentConfig) -> int:
    """``agent.noise_seq_len``, which :func:`resolve_noise` fills in (every agent's constructor calls it)."""
    if agent.noise_seq_len is None:
        raise ValueError("agent.noise=pink needs agent.noise_seq_len (core.modelfree.noise.resolve_noise)")
    return int(agent.noise_seq_len)


def uniform_warmup(
    agent: AgentConfig, step: int, action_dim: int, rng: np.random.Generator
) -> np.ndarray | None:
    """A uniform random action before ``learning_starts`` when ``agent.warmup = uniform`` (SB3), else None.
    The noise-exploring learners perturb it with their noise, as SB3 does (module docstring)."""
    if agent.warmup != "uniform" or step >= agent.learning_starts:
        return None
    return rng.uniform(-1.0, 1.0, size=action_dim).astype(np.float32)
