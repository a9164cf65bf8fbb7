"""DDPG+RND: random network distillation (Burda et al. 2018, "Exploration by Random Network Distillation")
as the exploration bonus of the model-free agent — the intrinsic-motivation peer of IM2C and I2A.

Definition (Burda et al., Section 2.2): a fixed, randomly initialised target network f: O → R^k and a
predictor f̂ trained by gradient descent on ||f̂(x) − f(x)||²; the intrinsic reward of a transition is the
predictor's error on the observation it leads to, i_t = ||f̂(s_{t+1}) − f(s_{t+1})||², large on what the
agent has rarely seen and falling as it is visited. As in the paper, observations are normalised by a
running mean and standard deviation and clipped to [−5, 5] before both networks (fixed after
``agent.learning_starts`` warm-up steps are counted in), and the bonus is divided by a running standard
deviation of the bonus, so ``agent.rnd_scale`` has one meaning on every task.

Our adaptation to an off-policy learner, stated plainly: Burda et al. train PPO with two value heads (the
intrinsic return non-episodic); here the bonus is added to the extrinsic reward of each sampled transition
at learn time, r = r_ext + β · i / σ_i (β = ``agent.rnd_scale``), computed with the current predictor, so
stored transitions never carry a stale bonus, and the predictor takes one Adam step on the same minibatch's
next observations. The networks: for images, a convolutional trunk of ``net.conv_channels`` (as our
encoder) and a linear head to ``agent.rnd_dim``; for vectors, an MLP of ``net.mlp_hidden``. No
implementation package was used: rllte-core's RND pins matplotlib 3.6, huggingface-hub 0.14 and
torchvision, which do not fit this project's pinned CPU torch.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import torch
from torch import nn

from core.config import Config
from core.envs.spec import EnvSpec
from core.modelfree.agent import ModelFreeAgent
from core.modelfree.networks import make_encoder
from core.modelfree.replay import PixelBatch

OBS_CLIP = 5.0
"""Normalised observations are clipped to [−5, 5] (Burda et al.)."""


class RunningMeanStd(nn.Module):
    """Running mean and variance (Chan et al.'s parallel update), as buffers that travel with the state."""

    mean: torch.Tensor
    var: torch.Tensor
    count: torch.Tensor

    def __init__(self, shape: tuple[int, ...]) -> None:
        super().__init__()
        self.register_buffer("mean", torch.zeros(shape))
        self.register_buffer("var", torch.ones(shape))
        self.register_buffer("count", torch.tensor(1e-4))

    @torch.no_grad()
    def update(self, batch: torch.Tensor) -> None:
        batch_mean, batch_var, n = batch.mean(0), batch.var(0, unbiased=False), batch.shape[0]
        delta = batch_mean - self.mean
        total = self.count + n
        self.mean += delta * n / total
        moment = self.var * self.count + batch_var * n + delta.pow(2) * self.count * n / total
        self.var.copy_(moment / total)
        self.count.copy_(total)

    def std(self) -> torch.Tensor:
        return self.var.clamp(min=1e-8).sqrt()


class RandomNetworkDistillation(nn.Module):
    """The fixed random target f, the predictor f̂, and the normalisers of observations and bonus."""

    def __init__(self, config: Config, spec: EnvSpec, generator_seed: int) -> None:
        super().__init__()
        torch.manual_seed(generator_seed)  # the target's random weights come from the run's seed
        width, out = config.net.latent_dim, config.agent.rnd_dim
        # RND's own networks have the shape of a learned encoder (ReLU latent) whatever the learner's encoder.
        net = dataclasses.replace(config.net, encoder="learned", latent_activation="relu")
        self.target = nn.Sequential(make_encoder(net, spec), nn.Linear(width, out))
        self.predictor = nn.Sequential(make_encoder(net, spec), nn.Linear(width, out))
        self.target.requires_grad_(False)
        self.prepare = self.target[0].prepare
        image = spec.obs_kind == "image"
        shape = (spec.obs_shape[2], *spec.obs_shape[:2]) if image else tuple(spec.obs_shape)
        self.obs_stats = RunningMeanStd(shape)
        self.bonus_stats = RunningMeanStd(())
        self.optimizer = torch.optim.Adam(self.predictor.parameters(), lr=config.agent.rnd_lr)

    def _normalised(self, obs: torch.Tensor) -> torch.Tensor:
        x = self.prepare(obs)
        return ((x - self.obs_stats.mean) / self.obs_stats.std()).clamp(-OBS_CLIP, OBS_CLIP)

    def error(self, obs: torch.Tensor) -> torch.Tensor:
        """||f̂(x) − f(x)||² per observation ``[N]`` (the unnormalised bonus), with gradients to f̂."""
        x = self._normalised(obs)
        with torch.no_grad():
            target = self.target(x)
        return (self.predictor(x) - target).pow(2).sum(1)

    @torch.no_grad()
    def observe(self, obs: torch.Tensor) -> None:
        """Count observations into the normalisation statistics."""
        self.obs_stats.update(self.prepare(obs))

    def bonus_and_update(self, next_obs: torch.Tensor) -> tuple[torch.Tensor, float]:
        """The normalised bonus i / σ_i of each next observation ``[N]`` (before this step), and one Adam step
        of the predictor on them; returns (bonus, predictor loss)."""
        error = self.error(next_obs)
        with torch.no_grad():
            self.bonus_stats.update(error.detach())
            bonus = error.detach() / self.bonus_stats.std()
        loss = error.mean()
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        return bonus, float(loss.detach())


class RNDAgent(ModelFreeAgent):
    """The model-free agent (DDPG or CACLA by ``agent.ac``) learning from r = r_ext + β · RND bonus."""

    def __init__(self, config: Config, spec: EnvSpec, rng: np.random.Generator) -> None:
        super().__init__(config, spec, rng)
        state = torch.get_rng_state()
        self.rnd = RandomNetworkDistillation(config, spec, int(rng.integers(0, 2**62))).to(self.device)
        torch.set_rng_state(state)  # the learner's initialisation stream is not shifted by RND's
        self._bonus: list[float] = []
        self._pending: list[np.ndarray] = []

    def observe(self, transition: Any) -> None:
        super().observe(transition)
        if self.steps <= self.config.agent.learning_starts:  # warm-up steps define the normalisation
            self._pending.append(np.asarray(transition.next_obs))
            if len(self._pending) >= 64 or self.steps == self.config.agent.learning_starts:
                self.rnd.observe(torch.from_numpy(np.stack(self._pending)).to(self.device))
                self._pending = []

    def learn_minibatch(self) -> dict[str, float]:
        batch = self.replay.sample(self.config.agent.batch_size, self.rng)
        if self.device.type != "cpu":
            batch = type(batch)(*(t.to(self.device) for t in batch))
        bonus, rnd_loss = self.rnd.bonus_and_update(batch.next_obs)
        self._bonus.append(float(bonus.mean()))
        shaped = PixelBatch(
            obs=batch.obs,
            action=batch.action,
            reward=batch.reward_ext + self.config.agent.rnd_scale * bonus,
            next_obs=batch.next_obs,
            terminated=batch.terminated,
            reward_ext=batch.reward_ext,
        )
        self.updates += 1
        return {**self.learner.update(shaped), "losses/rnd_predictor": rnd_loss}

    def episode_diagnostics(self) -> dict[str, float]:
        out = super().episode_diagnostics()
        out["rnd/bonus"] = float(np.mean(self._bonus)) if self._bonus else float("nan")
        self._bonus = []
        return out

    def state_dict(self) -> dict[str, Any]:
        state = super().state_dict()
        state["rnd"] = {"modules": self.rnd.state_dict(), "optimizer": self.rnd.optimizer.state_dict()}
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.rnd.load_state_dict(state["rnd"]["modules"])
        self.rnd.optimizer.load_state_dict(state["rnd"]["optimizer"])

