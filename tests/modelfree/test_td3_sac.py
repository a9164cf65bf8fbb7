"""TD3 and SAC as the equations say: TD3's clipped double-Q target at a smoothed target action and its delayed
actor and targets; SAC's squashed-Gaussian log-probability, its soft target, and α driving the entropy toward
its target; the textbook vector networks; exploration; a resumed run equals a straight one."""

from __future__ import annotations

import copy
import csv

import numpy as np
import pytest
import torch
from torch.distributions import Normal, TransformedDistribution
from torch.distributions.transforms import TanhTransform

from core.config import load_config
from core.envs.spec import EnvSpec
from core.modelfree.learners import make_learner
from core.modelfree.networks import ScaledObservation, SquashedGaussianActor
from core.modelfree.replay import PixelBatch
from core.runs.trainer import train

VECTOR = EnvSpec(obs_shape=(3,), action_dim=2, obs_kind="vector", obs_dtype="float32",
                 obs_low=(-1.0, -1.0, -8.0), obs_high=(1.0, 1.0, 8.0))
IMAGE = EnvSpec(obs_shape=(32, 64, 3), action_dim=1)
TEXTBOOK = ["net.encoder=none", "net.mlp_hidden=16,16"]


def _learner(ac: str, *extra: str, spec: EnvSpec = VECTOR):
    torch.manual_seed(0)
    config = load_config("default", [f"agent.ac={ac}", *TEXTBOOK, *extra])
    return make_learner(config.net, config.agent, spec)


def _batch(size: int = 32, seed: int = 0, spec: EnvSpec = VECTOR) -> PixelBatch:
    g = torch.Generator().manual_seed(seed)
    obs = torch.rand(size, *spec.obs_shape, generator=g) * 2 - 1
    next_obs = torch.rand(size, *spec.obs_shape, generator=g) * 2 - 1
    action = torch.rand(size, spec.action_dim, generator=g) * 2 - 1
    reward = torch.randn(size, generator=g)
    terminated = (torch.rand(size, generator=g) < 0.2).float()
    return PixelBatch(obs, action, reward, next_obs, terminated, reward)


def _target_at_seed(learner, seed: int):
    """A batch, its next latents and the learner's TD target drawn at torch seed ``seed``; the generator is
    reset to ``seed`` afterwards, so the reference computation draws the same noise."""
    data = _batch()
    phi = learner.encode(data.next_obs)
    torch.manual_seed(seed)
    target = learner.td_target(data.reward, phi, data.terminated)
    torch.manual_seed(seed)
    return data, phi, target


def test_textbook_network_reads_the_scaled_observation_through_mlp_heads():
    learner = _learner("td3")
    assert isinstance(learner.encoder, ScaledObservation) and learner.decoder is None
    assert learner.latent_dim == 3
    obs = torch.tensor([[1.0, -1.0, 8.0], [0.0, 0.5, -4.0]])
    torch.testing.assert_close(learner.encode(obs), torch.tensor([[1.0, -1.0, 1.0], [0.0, 0.5, -0.5]]))
    hidden = [m.out_features for m in learner.actor.net if isinstance(m, torch.nn.Linear)]
    assert hidden == [16, 16, 2]
    assert [m.out_features for m in learner.critic.q1.net if isinstance(m, torch.nn.Linear)] == [16, 16, 1]
    with pytest.raises(ValueError, match="vector observations"):
        _learner("sac", spec=IMAGE)


def test_observation_scaling_none_feeds_the_raw_observation_like_sb3():
    for encoder in ("none", "learned"):
        learner = _learner("td3", f"net.encoder={encoder}", "net.observation_scaling=none")
        obs = torch.tensor([[1.0, -1.0, 8.0], [0.0, 0.5, -4.0]])
        torch.testing.assert_close(learner.encoder.prepare(obs), obs)
    assert torch.equal(_learner("td3").encoder.prepare(obs)[:, 2], torch.tensor([1.0, -0.5]))


def test_td3_target_is_the_smaller_target_critic_at_a_smoothed_target_action():
    learner = _learner("td3", "agent.target_noise=0.3", "agent.target_noise_clip=0.4")
    with torch.no_grad():  # targets apart from the online networks, so the minimum is not trivially either
        for p in learner.target_critic.q2.parameters():
            p.add_(0.3 * torch.randn_like(p))
    data, phi, got = _target_at_seed(learner, 7)
    with torch.no_grad():
        mu = learner.target_actor(phi)
        noise = (torch.randn_like(mu) * 0.3).clamp(-0.4, 0.4)
        smoothed = (mu + noise).clamp(-1, 1)
        q1 = learner.target_critic.q1(phi, smoothed)
        q2 = learner.target_critic.q2(phi, smoothed)
    expected = data.reward + 0.99 * (1 - data.terminated) * torch.minimum(q1, q2)
    torch.testing.assert_close(got, expected)
    assert bool((q1 != q2).any()) and bool((noise.abs() <= 0.4).all())
    assert float(noise.abs().max()) == pytest.approx(0.4)  # σ 0.3 over 64 draws reaches the clip


def test_td3_steps_actor_and_targets_every_second_update_only():
    learner = _learner("td3", "agent.tau=0.1")
    data = _batch()
    for update in range(1, 5):
        actor_before = copy.deepcopy(learner.actor.state_dict())
        target_before = copy.deepcopy(learner.target_critic.state_dict())
        critic_before = copy.deepcopy(learner.critic.state_dict())
        losses = learner.update(data)
        moved = lambda before, module: any(  # noqa: E731
            not torch.equal(before[k], v) for k, v in module.state_dict().items())
        assert moved(critic_before, learner.critic)  # the critics learn every update
        assert moved(actor_before, learner.actor) == (update % 2 == 0)
        assert moved(target_before, learner.target_critic) == (update % 2 == 0)
        assert ("losses/actor" in losses) == (update % 2 == 0)


@pytest.mark.parametrize("ac", ["ddpg", "td3", "sac"])
def test_q_value_is_the_smaller_twin_and_value_of_takes_it_at_the_policys_action(ac):
    learner = _learner(ac)
    data = _batch()
    phi = learner.encode(data.obs)
    with torch.no_grad():
        q = learner.critic(phi, data.action)
        expected = q if ac == "ddpg" else torch.minimum(q[0], q[1])
        assert torch.equal(learner.q_value(phi, data.action), expected)
        assert torch.equal(learner.value_of(phi), learner.q_value(phi, learner.actor(phi)))
    # A read-out, never part of a loss: the actor's forward inside value_of builds no graph.
    grad_on_in_actor = []
    hook = learner.actor.register_forward_hook(lambda *_: grad_on_in_actor.append(torch.is_grad_enabled()))
    learner.value_of(phi.detach())
    hook.remove()
    assert grad_on_in_actor == [False]


def test_squashed_gaussian_log_probability_matches_torch_distributions():
    torch.manual_seed(1)
    actor = SquashedGaussianActor(5, 3, (8,), "relu")
    latent = torch.randn(64, 5)
    eps = torch.randn(64, 3)
    action, log_prob = actor.sample(latent, eps)
    mean, log_std = actor.distribution(latent)
    reference = TransformedDistribution(Normal(mean, log_std.exp()), [TanhTransform()])
    u = mean + log_std.exp() * eps
    torch.testing.assert_close(action, torch.tanh(u))
    expected = Normal(mean, log_std.exp()).log_prob(u).sum(1) - torch.log1p(-torch.tanh(u).pow(2)).sum(1)
    torch.testing.assert_close(log_prob, expected, atol=1e-4, rtol=1e-4)
    inside = action.abs().max(dim=1).values < 0.99  # where atanh is well conditioned for the reference
    reference_log_prob = reference.log_prob(action).sum(1)
    torch.testing.assert_close(log_prob[inside], reference_log_prob[inside], atol=1e-3, rtol=1e-3)
    torch.testing.assert_close(actor(latent), torch.tanh(mean))  # the deployed action is deterministic


def test_sb3_log_probability_arithmetic_is_the_same_function_floored_where_the_action_saturates():
    """``net.sac_log_prob = sb3``: SB3's Normal(m, σ).log_prob(u) − Σ log(1 − tanh(u)² + 10⁻⁶). Equal to the
    exact arithmetic away from saturation; where tanh(u) rounds to ±1 the exact one keeps counting
    −log(1 − tanh²) ≈ 2|u| − 2 log 2 and SB3's stops at log 10⁶ per dimension."""
    torch.manual_seed(2)
    exact = SquashedGaussianActor(5, 2, (8,), "relu")
    sb3 = SquashedGaussianActor(5, 2, (8,), "relu", log_prob="sb3")
    sb3.load_state_dict(exact.state_dict())
    latent, eps = torch.randn(256, 5), torch.randn(256, 2)
    (a_exact, lp_exact), (a_sb3, lp_sb3) = exact.sample(latent, eps), sb3.sample(latent, eps)
    torch.testing.assert_close(a_sb3, a_exact)
    moderate = a_exact.abs().max(dim=1).values < 0.99
    assert moderate.sum() > 200
    torch.testing.assert_close(lp_sb3[moderate], lp_exact[moderate], atol=1e-4, rtol=1e-4)
    with torch.no_grad():  # m = 12, σ = e⁻²⁰ and ε = 0: u = 12, where tanh(u) is 1 in float32
        for actor in (exact, sb3):
            actor.mean.weight.zero_()
            actor.mean.bias.fill_(12.0)
            actor.log_std.weight.zero_()
            actor.log_std.bias.fill_(-20.0)
    _, far_exact = exact.sample(latent[:1], torch.zeros(1, 2))
    _, far_sb3 = sb3.sample(latent[:1], torch.zeros(1, 2))
    gaussian = 2 * (20.0 - 0.5 * np.log(2 * np.pi))
    correction = 2 * (2 * 12.0 - 2 * np.log(2.0))
    assert far_exact.item() == pytest.approx(gaussian + correction, rel=1e-4)
    assert far_sb3.item() == pytest.approx(gaussian - 2 * np.log(1e-6), rel=1e-4)


def test_sac_target_is_the_soft_value_of_the_smaller_target_critic():
    learner = _learner("sac", "agent.alpha_init=0.5")
    data, phi, got = _target_at_seed(learner, 3)
    with torch.no_grad():
        action, log_prob = learner.actor.sample(phi)
        value = learner.target_critic(phi, action).min(dim=0).values - 0.5 * log_prob
    torch.testing.assert_close(got, data.reward + 0.99 * (1 - data.terminated) * value)
    assert not hasattr(learner, "target_actor")


@pytest.mark.parametrize("target_entropy", [-8.0, 4.0])
def test_sac_temperature_drives_the_entropy_toward_its_target(target_entropy):
    """Entropy above the target (−8 for 2 actions is far below any initial policy's): α falls; a target above
    what a squashed 2-D policy can reach (+4): α rises — both monotonically, as the α loss says."""
    learner = _learner("sac", f"agent.target_entropy={target_entropy}", "agent.actor_lr=3e-3")
    alphas = [learner.alpha]
    for seed in range(30):
        learner.update(_batch(seed=seed))
        alphas.append(learner.alpha)
    steps = np.diff(alphas)
    if target_entropy < 0:
        assert np.all(steps < 0) and alphas[-1] < 0.95
    else:
        assert np.all(steps > 0) and alphas[-1] > 1.05


def test_sac_explores_by_sampling_its_policy_around_the_chosen_action():
    learner = _learner("sac")
    latent = learner.encode(torch.tensor([[0.2, -0.3, 1.0]]))[0]
    rng = np.random.default_rng(0)
    chosen = learner.policy(latent[None])[0].numpy()
    samples = np.stack([learner.explore(chosen, latent, 10_000, rng) for _ in range(4000)])
    with torch.no_grad():
        mean, log_std = learner.actor.distribution(latent[None])
    pre_tanh = np.arctanh(np.clip(samples, -0.999999, 0.999999))
    np.testing.assert_allclose(pre_tanh.mean(0), mean[0].numpy(), atol=0.06)
    np.testing.assert_allclose(pre_tanh.std(0), log_std[0].exp().numpy(), rtol=0.06)
    assert np.all(np.abs(samples) <= 1.0)


def test_uniform_warmup_and_ou_noise():
    learner = _learner("td3", "agent.warmup=uniform", "agent.learning_starts=100", "agent.noise=ou",
                       "agent.noise_std=0.3", "agent.noise_final_std=0.3")
    rng = np.random.default_rng(0)
    zero = np.zeros(2, dtype=np.float32)
    # Warm-up (SB3's _sample_action): a = clip(u + x, -1, 1), u ~ U(-1, 1), and the OU process x runs from the
    # first step. A copy of the generator replays the draws: u first, then the OU increment.
    replay, x = copy.deepcopy(rng), np.zeros(2)
    for _ in range(300):
        action = learner.explore(zero, torch.zeros(3), 5, rng)
        uniform = replay.uniform(-1.0, 1.0, size=2)
        x = x - 0.15 * x * 0.01 + 0.3 * np.sqrt(0.01) * replay.normal(size=2)
        np.testing.assert_allclose(action, np.clip(uniform + x, -1.0, 1.0), atol=1e-6)
    assert np.all(learner.noise.x != 0.0)
    learner.begin_episode()
    path = np.stack([learner.explore(zero, torch.zeros(3), 500, rng) for _ in range(200)])[:, 0]
    # Ornstein-Uhlenbeck with dt = 0.01: consecutive draws are strongly correlated, i.i.d. noise is not.
    assert np.corrcoef(path[:-1], path[1:])[0, 1] > 0.9
    learner.begin_episode()
    assert np.all(learner.noise.x == 0.0)


def _run(tmp_path, name: str, algo: str, steps: int, resume: bool = False, ac: str | None = None):
    overrides = [f"run.algo={algo}", "env.id=MountainCarContinuous-v0",
                 'env.kwargs={"max_episode_steps": 60}',
                 f"run.steps={steps}", "run.episodes=none", "run.eval_every=0", "run.final_eval=false",
                 "agent.learning_starts=30", "agent.batch_size=16", *TEXTBOOK, "run.checkpoint_every=1",
                 "dual.latent_buffer_size=500", "dual.latent_batch_size=8"]
    if ac:
        overrides.append(f"agent.ac={ac}")
    train(load_config("default", overrides), tmp_path / name, resume=resume, command="test")
    with (tmp_path / name / "metrics.csv").open() as handle:
        return [{k: v for k, v in row.items() if not k.startswith("time/") and k != "charts/sps"}
                for row in csv.DictReader(handle)]


@pytest.mark.parametrize(("algo", "ac"), [("td3", None), ("sac", None), ("i2a", "sac")])
def test_a_resumed_run_equals_a_straight_one(tmp_path, algo, ac):
    straight = _run(tmp_path, "straight", algo, 240, ac=ac)
    _run(tmp_path, "split", algo, 120, ac=ac)
    resumed = _run(tmp_path, "split", algo, 240, resume=True, ac=ac)
    assert len(straight) == 4 and resumed == straight
    assert all(np.isfinite(float(row["charts/start_value"])) for row in straight)
