"""The agent interface the trainer drives, and the model-free agent (a learner: DDPG, CACLA, TD3 or SAC).

Hooks (all methods share one loop, ``core.runs.trainer.train``; a method plugs in by implementing these):

* ``begin_episode(obs)`` — a training episode starts with observation ``obs`` (uint8 image or vector).
* ``act(obs, explore) -> (action, step_diagnostics)`` — ``explore=True`` during training (exploration
  noise, meta-control, anything with side effects); ``explore=False`` is the greedy deployment policy
  μ(f(s)) used by evaluation and must not change learning state. ``step_diagnostics`` is a dict of floats;
  the trainer averages each key over the episode's steps into the episode record (e.g. ``dual/horizon``).
* ``observe(transition)`` — the real transition after ``env.step``; the agent stores it (a dual-system agent
  stores r = r_ext + r_int).
* ``update_after_step()`` / ``update_after_episode()`` — learning; each returns a dict of float losses,
  averaged per key over the episode by the trainer (``losses/critic``, ``losses/rec``, ``losses/actor``...).
* ``episode_diagnostics()`` — called once at the end of each training episode; a dict of floats merged
  into the episode record and the CSV as is (e.g. ``dual/mb_decisions``, ``dual/itm_nodes``). Reset
  per-episode counters here.
* ``state_dict()`` / ``load_state_dict()`` — everything but replay buffers (weights, optimisers, noise
  state, counters, RNG state) in ``torch.load(weights_only=True)``-loadable form (tensors, numbers,
  strings, lists, dicts).
* ``replay_state_dict()`` / ``load_replay_state_dict()`` — the buffers, saved to a separate file.
* ``policy_state()`` — ``{"encoder", "actor", "bounds"}`` state dicts of the deployable policy
  (``core.runs.policy`` rebuilds it from the run's ``net`` config).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np
import torch

from core.config import AgentConfig, Config
from core.envs.spec import EnvSpec
from core.modelfree.learners import Learner, make_learner
from core.modelfree.noise import resolve_noise
from core.modelfree.replay import PixelReplay

B = TypeVar("B", bound=tuple)


@dataclass
class Transition:
    """One real environment step (s_t, a_t, r_t^ext, s_{t+1}); learners never see the env's info dict."""

    obs: np.ndarray
    action: np.ndarray
    reward: float
    next_obs: np.ndarray
    terminated: bool
    truncated: bool


class Agent(Protocol):
    """The interface ``core.runs.trainer.train`` drives; see the module docstring for each hook's contract."""

    def begin_episode(self, obs: np.ndarray) -> None: ...

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]: ...

    def observe(self, transition: Transition) -> None: ...

    def update_after_step(self) -> dict[str, float]: ...

    def update_after_episode(self) -> dict[str, float]: ...

    def episode_diagnostics(self) -> dict[str, float]: ...

    def state_dict(self) -> dict[str, Any]: ...

    def load_state_dict(self, state: dict[str, Any]) -> None: ...

    def replay_state_dict(self) -> dict[str, Any]: ...

    def load_replay_state_dict(self, state: dict[str, Any]) -> None: ...

    def policy_state(self) -> dict[str, dict[str, torch.Tensor]]: ...


def generator_state(rng: np.random.Generator) -> str:
    """A NumPy generator's state as a JSON string (safe under ``torch.load(weights_only=True)``)."""
    return json.dumps(rng.bit_generator.state)


def restore_generator(rng: np.random.Generator, state: str) -> None:
    rng.bit_generator.state = json.loads(state)


class UpdateSchedule:
    """When the learner updates and how often (Algorithm 2, lines 26-28): after every env step
    (``agent.update_schedule = per_step``, ``updates_per_step`` minibatches) or after every episode
    (``per_episode``, the released code), once ``learning_starts`` steps are in the replay. Every agent holds
    one; ``run(moment, ...)`` averages the losses of its minibatch updates per key."""

    def __init__(self, agent: AgentConfig) -> None:
        self.config = agent

    def run(
        self, moment: str, steps: int, replay_size: int, minibatch: Callable[[], dict[str, float]]
    ) -> dict[str, float]:
        """At ``moment`` (``per_step``: after an env step; ``per_episode``: after an episode), the schedule's
        minibatch updates if it is the configured one and ``learning_starts`` steps are in the replay."""
        cfg = self.config
        if cfg.update_schedule != moment or steps < cfg.learning_starts or replay_size == 0:
            return {}
        count = cfg.updates_per_step if moment == "per_step" else cfg.updates_per_episode
        totals: dict[str, float] = {}
        counts: dict[str, int] = {}
        for _ in range(count):
            for key, value in minibatch().items():
                totals[key] = totals.get(key, 0.0) + value
                counts[key] = counts.get(key, 0) + 1
        return {key: value / counts[key] for key, value in totals.items()}


def to_device(batch: B, device: torch.device) -> B:
    """A replay batch (named tuple of tensors) on ``device``; the same object on the CPU."""
    if device.type == "cpu":
        return batch
    return type(batch)(*(t.to(device) for t in batch))


class LearnerAgent:
    """What every agent of this package and of ``core.dual`` holds and does the same way: a learner
    (``agent.ac``: DDPG, CACLA, TD3, SAC; ``core.modelfree.learners``), a pixel replay, the update schedule,
    the step counters and the run's generator; encoding one observation, the greedy policy, the schedule's
    hooks and persistence. The method itself (``act``, ``observe``, ``episode_diagnostics``) is each agent's
    own: ``ModelFreeAgent`` below; ``core.dual.im2c.IM2C``, ``core.dual.i2a.I2A``, ``core.dual.baselines``."""

    replay: PixelReplay

    def __init__(self, config: Config, spec: EnvSpec, rng: np.random.Generator) -> None:
        self.config = config
        self.spec = spec
        self.rng = rng
        self.device = torch.device(config.run.device)
        # pink noise's sequence length is the env's episode length (resolve_noise; other noises: as given)
        self.learner = make_learner(config.net, resolve_noise(config), spec).to(self.device)
        self.schedule = UpdateSchedule(config.agent)
        self.steps = 0
        """Training environment steps observed (drives noise annealing and learning_starts)."""
        self.updates = 0
        """Minibatch updates done."""

    def begin_episode(self, obs: np.ndarray) -> None:
        self.replay.start_episode(obs)
        self.learner.begin_episode()

    def encode(self, obs: np.ndarray) -> torch.Tensor:
        """φ = f(s) of one observation, ``[1, latent]`` on the CPU."""
        obs_tensor = torch.from_numpy(np.ascontiguousarray(obs)).unsqueeze(0).to(self.device)
        return self.learner.encode(obs_tensor).cpu()

    @torch.no_grad()
    def encode_batch(self, obs: torch.Tensor) -> torch.Tensor:
        """φ = f(s) of stored observations ``[B, ...]``: ``[B, latent]`` on the CPU, without gradient."""
        return self.learner.encode(obs.to(self.device)).cpu()

    def actor(self, latent: torch.Tensor) -> torch.Tensor:
        """μ(φ), the learner's deterministic action, on the CPU (what the planner starts from)."""
        return self.learner.policy(latent.to(self.device)).cpu()

    def greedy(self, latent: torch.Tensor) -> tuple[np.ndarray, dict[str, float]]:
        """``act(obs, explore=False)``: the deployed policy μ(f(s)), without side effects."""
        return self.actor(latent)[0].numpy().astype(np.float32), {}

    def explore(self, action: np.ndarray, latent: torch.Tensor) -> tuple[np.ndarray, dict[str, float]]:
        """The executed action: the learner's exploration around ``action`` (Algorithm 2, line 20)."""
        return self.learner.explore(action, latent[0], self.steps, self.rng).astype(np.float32), {}

    def value_and_gradient(self, latent: np.ndarray) -> tuple[float, np.ndarray]:
        """V(φ) = Q(φ, μ(φ)) of the online critic (twins: the smaller) and ∇_φ V through the critic and μ, of
        one latent ``[latent]`` (float64 in and out): what a dual planner reads at its plan's end
        (`core.dual.planning.TerminalValue`). The networks' weights get no gradient."""
        phi = torch.as_tensor(latent, dtype=torch.float32, device=self.device).reshape(1, -1)
        value, grad = self.learner.value_and_gradient(phi)
        return float(value[0]), grad[0].double().cpu().numpy()

    def start_value(self, obs: np.ndarray) -> float:
        """The critic's value of the policy's action at ``obs`` (twins: the smaller)."""
        return float(self.learner.value_of(self.encode(obs).to(self.device))[0])

    def learn_minibatch(self) -> dict[str, float]:
        """One minibatch from the pixel replay and the learner's update (Algorithm 2, lines 26-28)."""
        batch = to_device(self.replay.sample(self.config.agent.batch_size, self.rng), self.device)
        self.updates += 1
        return self.learner.update(batch)

    def update_after_step(self) -> dict[str, float]:
        return self.schedule.run("per_step", self.steps, len(self.replay), self.learn_minibatch)

    def update_after_episode(self) -> dict[str, float]:
        return self.schedule.run("per_episode", self.steps, len(self.replay), self.learn_minibatch)

    def state_dict(self) -> dict[str, Any]:
        return {
            "learner": self.learner.full_state_dict(),
            "steps": self.steps,
            "updates": self.updates,
            "rng": generator_state(self.rng),
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.learner.load_full_state_dict(state["learner"])
        self.steps = int(state["steps"])
        self.updates = int(state["updates"])
        restore_generator(self.rng, state["rng"])

    def replay_state_dict(self) -> dict[str, Any]:
        return {"pixel": self.replay.state_dict()}

    def load_replay_state_dict(self, state: dict[str, Any]) -> None:
        self.replay.load_state_dict(state["pixel"])

    def policy_state(self) -> dict[str, dict[str, torch.Tensor]]:
        return self.learner.policy_state()


class ModelFreeAgent(LearnerAgent):
    """The learner alone with its pixel replay: act with the learner's exploration around μ(f(s)), store the
    extrinsic reward, update on the schedule."""

    def __init__(self, config: Config, spec: EnvSpec, rng: np.random.Generator) -> None:
        super().__init__(config, spec, rng)
        self.replay = PixelReplay(config.agent.buffer_size, spec.obs_shape, spec.action_dim, spec.obs_dtype)

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        return act_model_free(self, obs, explore)

    def observe(self, transition: Transition) -> None:
        store_extrinsic(self, transition)

    def episode_diagnostics(self) -> dict[str, float]:
        return learner_diagnostics(self.learner, self.steps, len(self.replay))


def act_model_free(
    agent: LearnerAgent, obs: np.ndarray, explore: bool
) -> tuple[np.ndarray, dict[str, float]]:
    """Model-free acting: μ(f(s)), with the learner's exploration around it when ``explore``."""
    latent = agent.encode(obs)
    if not explore:
        return agent.greedy(latent)
    return agent.explore(agent.actor(latent)[0].numpy(), latent)


def store_extrinsic(agent: LearnerAgent, transition: Transition) -> None:
    """The real transition into the pixel replay with its extrinsic reward; one more env step."""
    agent.replay.add(transition.action, transition.reward, transition.next_obs, transition.terminated,
                     reward_ext=transition.reward)
    agent.steps += 1


def learner_diagnostics(learner: Learner, steps: int, replay_size: int) -> dict[str, float]:
    """Per-episode diagnostics every agent reports: the exploration's scale and the replay's size."""
    noise = getattr(learner, "noise", None)
    out = {"charts/replay_size": float(replay_size)}
    if noise is not None:
        out = {"charts/noise_std": noise.std_at(steps), **out}
    else:
        out["charts/alpha"] = float(getattr(learner, "alpha", math.nan))
    return out
