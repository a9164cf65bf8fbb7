"""The agent interface the trainer drives, and the model-free agent (DDPG / off-policy CACLA).

Hooks (all methods share one loop, ``core.runs.trainer.train``; a method plugs in by implementing these):

* ``begin_episode(obs)`` — a training episode starts with observation ``obs`` (uint8 image or vector).
* ``act(obs, explore) -> (action, step_diagnostics)`` — ``explore=True`` during training (exploration
  noise, meta-control, anything with side effects); ``explore=False`` is the greedy deployment policy
  μ(f(s)) used by evaluation and must not change learning state. ``step_diagnostics`` is a dict of floats;
  the trainer averages each key over the episode's steps into the episode record (e.g. ``dual/horizon``).
* ``observe(transition)`` — the real transition after ``env.step``; the agent stores it (and may shape the
  stored reward, e.g. r = r_ext + r_int, via :meth:`ModelFreeAgent.stored_reward`).
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
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import torch

from core.config import Config
from core.envs.spec import EnvSpec
from core.modelfree.actor_critic import ActorCritic
from core.modelfree.replay import PixelReplay


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


class GaussianNoise:
    """Exploration noise a ← clip(a + N(0, σ²), −1, 1) (Algorithm 2, line 20), in the agents' normalised
    action space, so σ is σ/2 of each dimension's range in the env's units (``core.envs.spec``).

    σ decays linearly from ``std`` to ``final_std`` over ``anneal_steps`` training steps (the ``paper``
    profile keeps σ = 1). Draws come from the agent's seeded generator.
    """

    def __init__(self, std: float, final_std: float, anneal_steps: int) -> None:
        self.std, self.final_std, self.anneal_steps = std, final_std, max(1, anneal_steps)

    def std_at(self, step: int) -> float:
        fraction = min(1.0, step / self.anneal_steps)
        return self.std + fraction * (self.final_std - self.std)

    def perturb(self, action: np.ndarray, step: int, rng: np.random.Generator) -> np.ndarray:
        noisy = action + rng.normal(0.0, self.std_at(step), size=action.shape)
        return np.clip(noisy, -1.0, 1.0).astype(np.float32)


def generator_state(rng: np.random.Generator) -> str:
    """A NumPy generator's state as a JSON string (safe under ``torch.load(weights_only=True)``)."""
    return json.dumps(rng.bit_generator.state)


def restore_generator(rng: np.random.Generator, state: str) -> None:
    rng.bit_generator.state = json.loads(state)


class ModelFreeAgent:
    """DDPG or off-policy CACLA (``agent.ac``) on the critic-autoencoder of Fig. 1 with pixel replay.

    Subclass it (or wrap it) for the dual-system methods: override ``act`` for meta-control,
    ``stored_reward`` for r = r_ext + r_int, and extend the update/diagnostic hooks.
    """

    def __init__(self, config: Config, spec: EnvSpec, rng: np.random.Generator) -> None:
        self.config = config
        self.spec = spec
        self.rng = rng
        self.device = torch.device(config.run.device)
        self.learner = ActorCritic(config.net, config.agent, spec).to(self.device)
        self.replay = PixelReplay(config.agent.buffer_size, spec.obs_shape, spec.action_dim, spec.obs_dtype)
        agent_cfg = config.agent
        self.noise = GaussianNoise(
            agent_cfg.noise_std, agent_cfg.noise_final_std, agent_cfg.noise_anneal_steps
        )
        self.steps = 0
        """Training environment steps observed (drives noise annealing and learning_starts)."""
        self.updates = 0
        """Minibatch updates done."""

    # -- acting ----------------------------------------------------------------------------------
    def begin_episode(self, obs: np.ndarray) -> None:
        self.replay.start_episode(obs)

    def greedy_action(self, obs: np.ndarray) -> np.ndarray:
        """μ(f(s)) for one observation, in the normalised action space."""
        obs_tensor = torch.from_numpy(np.ascontiguousarray(obs)).unsqueeze(0).to(self.device)
        return self.learner.policy(self.learner.encode(obs_tensor))[0].cpu().numpy()

    def act(self, obs: np.ndarray, explore: bool) -> tuple[np.ndarray, dict[str, float]]:
        action = self.greedy_action(obs)
        if explore:
            action = self.noise.perturb(action, self.steps, self.rng)
        return action.astype(np.float32), {}

    # -- storing ---------------------------------------------------------------------------------
    def stored_reward(self, transition: Transition) -> float:
        """The reward the critic learns from; the extrinsic reward here (dual methods add r_int)."""
        return transition.reward

    def observe(self, transition: Transition) -> None:
        self.replay.add(
            transition.action,
            self.stored_reward(transition),
            transition.next_obs,
            transition.terminated,
            reward_ext=transition.reward,
        )
        self.steps += 1

    # -- learning --------------------------------------------------------------------------------
    def ready_to_learn(self) -> bool:
        return self.steps >= self.config.agent.learning_starts and len(self.replay) > 0

    def learn_minibatch(self) -> dict[str, float]:
        """Sample one minibatch from the pixel replay and run the full update (Algorithm 2, lines 26-28)."""
        batch = self.replay.sample(self.config.agent.batch_size, self.rng)
        if self.device.type != "cpu":
            batch = type(batch)(*(t.to(self.device) for t in batch))
        self.updates += 1
        return self.learner.update_pixels(batch)

    def _learn(self, count: int) -> dict[str, float]:
        if not self.ready_to_learn():
            return {}
        totals: dict[str, float] = {}
        for _ in range(count):
            for key, value in self.learn_minibatch().items():
                totals[key] = totals.get(key, 0.0) + value
        return {key: value / count for key, value in totals.items()}

    def update_after_step(self) -> dict[str, float]:
        if self.config.agent.update_schedule != "per_step":
            return {}
        return self._learn(self.config.agent.updates_per_step)

    def update_after_episode(self) -> dict[str, float]:
        if self.config.agent.update_schedule != "per_episode":
            return {}
        return self._learn(self.config.agent.updates_per_episode)

    def episode_diagnostics(self) -> dict[str, float]:
        return {
            "charts/noise_std": self.noise.std_at(self.steps),
            "charts/replay_size": float(len(self.replay)),
        }

    # -- persistence -----------------------------------------------------------------------------
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
        learner = self.learner
        return {
            "encoder": learner.encoder.state_dict(),
            "actor": learner.actor.state_dict(),
            "bounds": learner.bounds.state_dict(),
        }
