"""The whole off-policy training loop against Stable-Baselines3's, step by step (issue 28).

``test_sb3_equivalence.py`` checks one minibatch update. This checks everything around it, on a real env: the
uniform warm-up, the exploration noise on top of it, what goes into the replay (the scaled action, the next
observation at a time-limit truncation, the done flag), when the first update happens, the policy delay's
phase across updates, and the episode resets. SB3's DDPG, TD3 and SAC run 320 env steps of Pendulum-v1 (one
truncated episode and part of the next), and SB3's SAC 1 100 steps of dm_control's reacher-hard (the task of
study 3's grid 4: a 6-D unbounded observation, on which our scaling is the identity, a 2-D action and a
truncation at 1 000), while their random draws are recorded: the warm-up actions (``action_space.sample``),
the action noise (DDPG, TD3), SAC's exploration draws and the minibatch indices.
Our agent then runs the loop the trainer runs (``core.runs.trainer._Trainer._train_episode``'s calls, in its
order) from SB3's initial weights, with a generator that hands it SB3's draws in turn. TD3's target smoothing
draws match through a shared torch seed; SAC's update draws (torch, where its exploration draws from the
agent's generator) are handed over as ``test_sb3_equivalence`` does, in the order each side makes them. Every
executed action, and every weight at the end, must agree to float32 round-off.

On reacher-hard our SAC computes log π in SB3's arithmetic (``net.sac_log_prob = sb3``). In its own, exact
arithmetic the two runs part within a few hundred updates (median action gap 1.5·10⁻⁴ over steps 300-500,
10⁻³ after; measured), because SB3's Gaussian term loses precision in u − m when σ is small and its
squashing correction carries a 10⁻⁶ floor (``core.config.NetConfig.sac_log_prob``).

One difference is known and compensated here, not hidden: SB3 takes its first update after the step that
takes ``num_timesteps`` past ``learning_starts`` (after step 101 of 100 warm-up steps); ours after the 100th
step, before the first policy action, so ours makes one update more over a run. The test gives SB3 that update
with its own ``train()`` at the same moment (``_learn_with_ours_first_update``). Everything else is the same
code path as in a run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch

from core.config import load_config
from core.envs.gym_env import make_env
from core.modelfree.agent import Transition
from core.runs.methods import make_agent
from tests.modelfree.test_sb3_equivalence import _gap, _linears, _pairs

sb3 = pytest.importorskip("stable_baselines3", reason="the bench extra holds Stable-Baselines3")
from stable_baselines3.common.logger import configure  # noqa: E402
from stable_baselines3.common.noise import ActionNoise  # noqa: E402

HIDDEN = [32, 24]
BATCH = 32
WARMUP = 100


@dataclass(frozen=True)
class Case:
    env: str
    steps: int
    """Env steps: each case crosses one time-limit truncation (Pendulum's 200, reacher's 1 000) with learning
    on."""
    overrides: tuple[str, ...] = ()
    """Our agent's settings beyond SB3's (module docstring)."""
    tolerance: float = 1e-4
    """Largest gap in an executed action and in a weight at the end: float32 round-off of differently
    ordered sums, carried through the updates and the env's dynamics."""


PENDULUM = Case("Pendulum-v1", 320, ("net.observation_scaling=none",))
REACHER = Case("dm_control/reacher-hard-v0", 1100, ("net.sac_log_prob=sb3",), tolerance=1e-3)
"""1 001 updates: measured gaps 8.9·10⁻⁵ (action) and 9.0·10⁻⁵ (weight); in the exact arithmetic 6.8·10⁻²
and 3.4·10⁻²."""
NOISE = 0.1
"""DDPG's and TD3's Gaussian action noise (SAC explores by sampling its policy, with ε ~ N(0, 1))."""
TORCH_SEED = 7


class RecordingNoise(ActionNoise):
    """SB3's Gaussian action noise (NormalActionNoise's draw), keeping every draw it hands out."""

    def __init__(self, sigma: float, dim: int) -> None:
        super().__init__()
        self.sigma, self.dim, self.draws = sigma, dim, []

    def __call__(self) -> np.ndarray:
        draw = np.random.normal(0.0, self.sigma, size=self.dim)
        self.draws.append(draw)
        return draw


class ScriptedGenerator:
    """Hands our agent SB3's recorded draws in the order it asks for them; fails on any other request.
    The queues are filled by SB3's run, after our agent is built with this generator."""

    def __init__(self, scale: float) -> None:
        self.scale = scale
        self.queues: dict[str, list[np.ndarray]] = {"uniform": [], "normal": [], "integers": []}

    def _next(self, kind: str, size: Any) -> np.ndarray:
        assert self.queues[kind], f"our agent asked for one {kind} draw more than SB3 made"
        draw = np.asarray(self.queues[kind].pop(0))
        assert draw.size == np.empty(size).size, f"{kind}: SB3 drew {draw.shape}, ours asks for {size}"
        return draw.reshape(size)

    def uniform(self, low: float, high: float, size: Any) -> np.ndarray:
        assert (low, high) == (-1.0, 1.0)  # the warm-up action in the agents' normalised units
        return self._next("uniform", size)

    def normal(self, loc: float = 0.0, scale: float = 1.0, size: Any = None) -> np.ndarray:
        assert loc == 0.0 and abs(scale - self.scale) < 1e-12
        return self._next("normal", size)

    def integers(self, low: int, high: int, size: Any) -> np.ndarray:
        draw = self._next("integers", size)
        assert low <= draw.min() and draw.max() < high, "SB3 sampled a row ours does not hold"
        return draw


def _learn_with_ours_first_update(model: Any, steps: int) -> None:
    """SB3's own loop, with its first update moved to where ours takes it (module docstring)."""
    model.learn(total_timesteps=WARMUP)  # the warm-up: uniform actions plus noise, no update yet
    model.train(gradient_steps=1, batch_size=BATCH)
    model.learning_starts = WARMUP - 1  # from here on: a policy action, then one update, per step
    model.learn(total_timesteps=steps - WARMUP, reset_num_timesteps=False)


def _lr(ac: str) -> float:
    return 3e-4 if ac == "sac" else 1e-3


def _sb3_model(ac: str, case: Case) -> tuple[Any, RecordingNoise | None]:
    """SB3's model on Pendulum as gymnasium makes it; on dm_control, on our adapter's env (the flattened
    observation), which is what SB3's peer in the experiments trains on (``core.experiments.sb3_peer``)."""
    if case is PENDULUM:
        env = gym.make(case.env)
    else:
        env = make_env(load_config("vector", [f"env.id={case.env}"]).env).env
    noise = None if ac == "sac" else RecordingNoise(NOISE, env.action_space.shape[0])
    algo = {"ddpg": sb3.DDPG, "td3": sb3.TD3, "sac": sb3.SAC}[ac]
    model = algo("MlpPolicy", env, learning_rate=_lr(ac), batch_size=BATCH, buffer_size=case.steps,
                 learning_starts=WARMUP, action_noise=noise, seed=0, device="cpu",
                 policy_kwargs={"net_arch": HIDDEN})
    model.set_logger(configure(None, []))
    return model, noise


def _our_agent(ac: str, rng: ScriptedGenerator, case: Case) -> tuple[Any, Any]:
    """Our agent at SB3's settings (the SB3 peer's, with the raw observation SB3 feeds) and its env."""
    overrides = [f"env.id={case.env}", f"run.algo={ac}", f"net.mlp_hidden={HIDDEN}", *case.overrides,
                 f"agent.critic_lr={_lr(ac)}", f"agent.actor_lr={_lr(ac)}", f"agent.batch_size={BATCH}",
                 f"agent.buffer_size={case.steps}", f"agent.learning_starts={WARMUP}", "agent.warmup=uniform",
                 f"agent.noise_std={NOISE}", f"agent.noise_final_std={NOISE}", "agent.noise=gaussian"]
    config = load_config("vector", overrides)
    adapted = make_env(config.env)
    return make_agent(config, adapted.spec, rng), adapted.env


def _run_reference(
    model: Any,
    rng: ScriptedGenerator,
    noise: RecordingNoise | None,
    update_draws: list[torch.Tensor],
    monkeypatch: pytest.MonkeyPatch,
    steps: int,
) -> list[np.ndarray]:
    """SB3's run, recording its draws into our generator's queues (and SAC's update draws into
    ``update_draws``); its executed actions in [-1, 1]."""
    sample = model.action_space.sample

    def recorded_sample(*args: Any, **kwargs: Any) -> np.ndarray:
        action = sample(*args, **kwargs)
        rng.queues["uniform"].append(model.policy.scale_action(action))
        return action

    get_samples = model.replay_buffer._get_samples

    def recorded_get_samples(batch_inds: np.ndarray, env: Any = None) -> Any:
        rng.queues["integers"].append(batch_inds.copy())
        return get_samples(batch_inds, env)

    def recorded_rsample(distribution: Any, sample_shape: Any = torch.Size()) -> torch.Tensor:
        eps = torch.randn(distribution.loc.shape)  # SAC: one draw per action when acting, a batch per update
        if eps.shape[0] == 1:
            rng.queues["normal"].append(eps[0].numpy().astype(np.float64))
        else:
            update_draws.append(eps)
        return distribution.loc + distribution.scale * eps

    model.action_space.sample = recorded_sample
    model.replay_buffer._get_samples = recorded_get_samples
    if noise is not None:
        noise.draws = rng.queues["normal"]
    else:
        monkeypatch.setattr(torch.distributions.Normal, "rsample", recorded_rsample)
    torch.manual_seed(TORCH_SEED)
    _learn_with_ours_first_update(model, steps)
    monkeypatch.undo()
    return [model.replay_buffer.actions[t, 0].copy() for t in range(steps)]


def _run_ours(agent: Any, env: Any, steps: int) -> list[np.ndarray]:
    """The trainer's per-episode calls (``_Trainer._train_episode``), in its order, for ``steps`` steps."""
    torch.manual_seed(TORCH_SEED)
    executed: list[np.ndarray] = []
    obs, _ = env.reset(seed=0)
    agent.begin_episode(obs)
    while len(executed) < steps:
        action, _ = agent.act(obs, explore=True)
        next_obs, reward, terminated, truncated, _ = env.step(action)
        agent.observe(Transition(obs, action, float(reward), next_obs, bool(terminated), bool(truncated)))
        agent.update_after_step()
        executed.append(action.copy())
        obs = next_obs
        if terminated or truncated:
            agent.update_after_episode()
            obs, _ = env.reset()
            agent.begin_episode(obs)
    return executed


def _queue_update_draws(agent: Any, update_draws: list[torch.Tensor], monkeypatch) -> None:
    """Our SAC actor's ``sample`` on SB3's update draws: SB3 draws for the current states, then the next;
    ours bootstraps first, so each update's pair is handed over swapped."""
    swapped = [draw for k in range(0, len(update_draws), 2) for draw in update_draws[k: k + 2][::-1]]
    update_draws[:] = swapped  # consumed in place: the test checks that none is left
    actor = agent.learner.actor
    real_sample = type(actor).sample
    monkeypatch.setattr(
        actor, "sample", lambda latent, noise=None: real_sample(actor, latent, update_draws.pop(0))
    )


@pytest.mark.parametrize(
    ("ac", "case"),
    [("ddpg", PENDULUM), ("td3", PENDULUM), ("sac", PENDULUM), ("sac", REACHER)],
    ids=["ddpg-pendulum", "td3-pendulum", "sac-pendulum", "sac-reacher-hard"],
)
def test_training_loop_takes_stable_baselines3s_actions_and_weights(ac, case, monkeypatch):
    if case is REACHER:
        pytest.importorskip("dm_control", reason="the dmc extra holds dm_control")
    model, noise = _sb3_model(ac, case)
    rng = ScriptedGenerator(NOISE if noise is not None else 1.0)
    agent, env = _our_agent(ac, rng, case)
    pairs = _pairs(ac, model, agent.learner)
    with torch.no_grad():  # SB3's initial weights (the pairs are layer-aligned)
        for theirs, mine in pairs:
            for a, b in zip(_linears(theirs), _linears(mine), strict=True):
                b.weight.copy_(a.weight)
                b.bias.copy_(a.bias)
    update_draws: list[torch.Tensor] = []
    theirs = np.array(_run_reference(model, rng, noise, update_draws, monkeypatch, case.steps))
    if ac == "sac":
        assert len(update_draws) == 2 * (case.steps - WARMUP + 1)
        _queue_update_draws(agent, update_draws, monkeypatch)
    ours = np.array(_run_ours(agent, env, case.steps))
    left = [kind for kind, queue in [*rng.queues.items(), ("update", update_draws)] if queue]
    assert not left, f"ours left some of SB3's draws unused: {left}"
    gaps = np.abs(theirs - ours[:, : theirs.shape[1]]).max(axis=1)
    first = int(np.argmax(gaps > case.tolerance)) if (gaps > case.tolerance).any() else None
    assert first is None, f"{ac}: executed actions part at step {first} ({gaps[first]:.2e})"
    assert agent.updates == model._n_updates == case.steps - WARMUP + 1
    assert _gap(pairs) < case.tolerance
    moved = float(np.abs(theirs[WARMUP:] - theirs[WARMUP]).max())
    assert moved > 0.1  # the policy changed while learning: the loops did not agree by standing still
