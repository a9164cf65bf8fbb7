"""The dual-system agents' contracts: I2A's imagined transitions, meta-control, LA-Imagination, Alg. 3's
update, MVE's expanded target, world-model bookkeeping, greedy acting and checkpoints."""

from __future__ import annotations

import copy
import io
import re

import numpy as np
import pytest
import torch

from core.config import ConfigError, check_config, load_config
from core.dual.baselines import ValueExpansion
from core.dual.imagination import imagination_probability, la_imagination_rollout
from core.dual.meta_controller import MetaController
from core.dual.readings import resolve
from core.dual.world_models import LocalWorldModels
from core.envs.spec import EnvSpec
from core.modelfree.agent import Transition
from core.modelfree.learners import Learner, make_learner
from core.modelfree.learners.base import td_loss
from core.modelfree.networks import to_float_chw
from core.modelfree.replay import LatentBatch, PixelBatch
from core.runs.methods import make_agent
from tests.utils.paper_dual import paper_dual_overrides

SPEC = EnvSpec(obs_shape=(32, 64, 3), action_dim=1)
SMALL = ["net.conv_channels=4,4,4", "agent.buffer_size=300", "dual.latent_buffer_size=1000",
         "agent.batch_size=8", "dual.latent_batch_size=8"]
LITERAL = [*paper_dual_overrides(), "dual.intrinsic_scale=0.1"]
"""The paper's reading of the dual section (docs/dual-system.md, "Mechanisms": every repair off)."""


def _agent(algo: str, *overrides: str):
    torch.manual_seed(0)
    config = load_config("default", [f"run.algo={algo}", *SMALL, *overrides])
    return make_agent(config, SPEC, np.random.default_rng(0))


def _obs(seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, size=SPEC.obs_shape, dtype=np.uint8)


def _step(agent, obs: np.ndarray, reward: float = 0.0) -> np.ndarray:
    action, _ = agent.act(obs, explore=True)
    agent.observe(Transition(obs, action, reward, obs, False, False))
    return action


def test_i2a_adds_exactly_h_imagined_transitions_per_model_based_step() -> None:
    agent = _agent("i2a", *LITERAL)
    obs = _obs()
    agent.begin_episode(obs)
    model_based_steps = 0
    for _ in range(80):
        before_size, before_mb = len(agent.imagination.replay), len(agent.dual.counters.horizons)
        _step(agent, obs)
        added = len(agent.imagination.replay) - before_size
        if len(agent.dual.counters.horizons) > before_mb:
            model_based_steps += 1
            horizon = agent.dual.counters.horizons[-1]
            assert 1 <= horizon <= agent.config.dual.d_max
            assert added == horizon
        else:
            assert added == 0
    assert model_based_steps > 0  # a repeated image: the model improves, LP ≥ 0, model-based decisions
    assert agent.dual.counters.imagined == sum(agent.dual.counters.horizons) == len(agent.imagination.replay)


def test_arbitration_model_free_ablation_never_plans_but_keeps_intrinsic_reward() -> None:
    agent = _agent("im2c", *LITERAL, "dual.arbitration=model_free")
    obs = _obs()
    agent.begin_episode(obs)
    for _ in range(80):  # the same repeated image makes the full dual system go model-based (test above)
        _step(agent, obs)
    assert agent.dual.meta is None
    assert agent.dual.counters.horizons == []
    assert agent.dual.counters.mf_decisions == 80
    assert any(value != 0.0 for value in agent.dual.counters.intrinsic)


def test_plan_action_shift_is_the_distance_of_the_executed_action_from_the_actors() -> None:
    agent = _agent("im2c", *LITERAL, "dual.plan_lr=0.5")
    obs = _obs()
    agent.begin_episode(obs)
    for _ in range(80):
        _step(agent, obs)
    shifts = agent.dual.counters.action_shifts
    assert len(shifts) == len(agent.dual.counters.horizons) > 0
    assert all(0.0 <= shift <= 2.0 for shift in shifts)
    assert max(shifts) > 0.0  # a large α_plan moves the action
    diagnostics = agent.episode_diagnostics()
    assert diagnostics["dual/plan_action_shift"] == pytest.approx(float(np.mean(shifts)))


def test_im2c_stores_nothing_imagined_and_stores_r_ext_plus_r_int() -> None:
    agent = _agent("im2c", *LITERAL)
    obs = _obs(1)
    agent.begin_episode(obs)
    for _ in range(10):
        _step(agent, obs, reward=-0.25)
    assert not hasattr(agent, "imagination")
    stored = agent.replay.reward[:10]
    intrinsic = np.array(agent.dual.counters.intrinsic, dtype=np.float32)
    np.testing.assert_allclose(stored, -0.25 + intrinsic, atol=1e-6)
    np.testing.assert_allclose(agent.replay.reward_ext[:10], -0.25)
    # Released-code LP: the first error of a node gives LP = −1, so r_int = +c (the intrinsic scale).
    assert agent.dual.counters.intrinsic[0] == pytest.approx(agent.config.dual.intrinsic_scale)


def test_greedy_act_is_mu_of_f_and_changes_no_learning_state() -> None:
    agent = _agent("i2a")
    obs = _obs(2)
    agent.begin_episode(obs)
    for _ in range(15):
        _step(agent, obs)
    snapshot = copy.deepcopy((agent.dual.world.state_dict(), len(agent.replay), agent.dual.total_imagined,
                              agent.rng.bit_generator.state, agent.dual.counters.__dict__))
    action, _ = agent.act(_obs(3), explore=False)
    with torch.no_grad():
        expected = agent.learner.actor(agent.learner.encoder(to_float_chw(torch.from_numpy(_obs(3))[None])))
    np.testing.assert_allclose(action, expected[0].numpy(), atol=1e-6)
    after = (agent.dual.world.state_dict(), len(agent.replay), agent.dual.total_imagined,
             agent.rng.bit_generator.state, agent.dual.counters.__dict__)
    assert after[1:] == snapshot[1:]
    for part, tensors in snapshot[0].items():
        for key, value in tensors.items():
            torch.testing.assert_close(after[0][part][key], value, rtol=0, atol=0, equal_nan=True,
                                       msg=f"{part}.{key}")


def _global_world(*overrides: str) -> LocalWorldModels:
    config = load_config("default", [*LITERAL, *overrides])
    return LocalWorldModels(config.dual, latent_dim=4, action_dim=1, regions=False,
                            generator=torch.Generator().manual_seed(0), readings=resolve(config.dual))


def _actor():
    torch.manual_seed(1)
    return torch.nn.Sequential(torch.nn.Linear(4, 1), torch.nn.Tanh())


def test_meta_controller_model_free_when_lp_negative_and_fixed_horizon_when_reliable() -> None:
    world = _global_world()
    dual = world.config
    meta = MetaController(world, dual, fixed_horizon=3)
    phi = torch.rand(1, 4)
    actor = _actor()
    world.lp.record([0], [1.0])  # released reading: LP = −1
    decision = meta.decide(phi, 0, actor)
    assert not decision.model_based and decision.rollout is None
    torch.testing.assert_close(decision.action, actor(phi)[0].detach())
    world.lp.record([0], [0.5])  # means 1.0, 0.75: LP > 0
    decision = meta.decide(phi, 0, actor)
    assert decision.model_based and decision.rollout.depth == 3
    assert decision.plan is not None
    torch.testing.assert_close(decision.action, decision.plan.plan[0].clamp(-1, 1))


def test_la_imagination_probability_and_depth() -> None:
    world = _global_world()
    actor, phi, rng = _actor(), torch.rand(4), np.random.default_rng(0)
    assert imagination_probability(world, 0, 1.0) == 0.0
    assert la_imagination_rollout(phi, 0, world, actor, 6, 1.0, rng).depth == 0
    world.lp.record([0], [0.5])
    assert imagination_probability(world, 0, 1.0) == 1.0
    assert la_imagination_rollout(phi, 0, world, actor, 6, 1.0, rng).depth == 6
    world.lp.record([0], [7.5])  # window mean 4 → p = 1/4, each step continues with p
    assert imagination_probability(world, 0, 1.0) == pytest.approx(0.25)
    depths = np.array([la_imagination_rollout(phi, 0, world, actor, 6, 1.0, rng).depth for _ in range(3000)])
    assert (depths >= 1).mean() == pytest.approx(0.25, abs=0.03)
    assert (depths >= 2).mean() == pytest.approx(0.25**2, abs=0.02)


def _learner(ac: str = "ddpg") -> Learner:
    torch.manual_seed(3)
    config = load_config("default", ["net.conv_channels=4,4,4", f"agent.ac={ac}", "agent.critic_passes=1"])
    return make_learner(config.net, config.agent, SPEC)


def _batches(n: int = 6) -> tuple[PixelBatch, LatentBatch]:
    g = torch.Generator().manual_seed(5)
    pixel = PixelBatch(
        obs=torch.randint(0, 256, (n, 32, 64, 3), dtype=torch.uint8, generator=g),
        action=torch.rand(n, 1, generator=g) * 2 - 1, reward=torch.randn(n, generator=g),
        next_obs=torch.randint(0, 256, (n, 32, 64, 3), dtype=torch.uint8, generator=g),
        terminated=torch.zeros(n), reward_ext=torch.zeros(n),
    )
    latent = LatentBatch(latent=torch.rand(n, 32, generator=g), action=torch.rand(n, 1, generator=g) * 2 - 1,
                         reward=torch.randn(n, generator=g), next_latent=torch.rand(n, 32, generator=g),
                         done=torch.zeros(n))
    return pixel, latent


@pytest.mark.parametrize("ac", ["ddpg", "cacla", "td3", "sac"])
def test_imagination_update_is_algorithm_3_lines_34_to_37(ac: str) -> None:
    """Every learner: the same draws (TD3's smoothing, SAC's samples) in the same order on both sides."""
    learner = _learner(ac)
    reference = copy.deepcopy(learner)
    pixel, latent = _batches()
    torch.manual_seed(11)
    learner.update(pixel, latent)
    torch.manual_seed(11)

    ref, cfg = reference, reference.agent_config
    obs = to_float_chw(pixel.obs)
    with torch.no_grad():
        next_phi = ref.target_encoder(to_float_chw(pixel.next_obs))
        y_pixel = ref.td_target(pixel.reward, next_phi, pixel.terminated)
        y_latent = ref.td_target(latent.reward, latent.next_latent, latent.done)
    # Line 34: θ^Q fixed, encoder/decoder step on Eq. 4 of the pixel minibatch.
    phi = ref.encoder(obs)
    for p in ref.critic.parameters():
        p.requires_grad_(False)
    loss = cfg.lambda_rec * (ref.decoder(phi) - obs).pow(2).mean() + cfg.lambda_q * td_loss(
        ref.critic(phi, pixel.action), y_pixel, ref.twin_loss_weight)
    ref.critic_optimizer.zero_grad(set_to_none=True)
    loss.backward()
    ref.critic_optimizer.step()
    for p in ref.critic.parameters():
        p.requires_grad_(True)
    # Line 35: critic step on pixel (φ before the step, detached) + latent minibatches.
    phi_all = torch.cat([phi.detach(), latent.latent])
    y_all = torch.cat([y_pixel, y_latent])
    a_all = torch.cat([pixel.action, latent.action])
    ref.critic_optimizer.zero_grad(set_to_none=True)
    (cfg.lambda_q * td_loss(ref.critic(phi_all, a_all), y_all, ref.twin_loss_weight)).backward()
    ref.critic_optimizer.step()
    # Line 36: the learner's policy step on both minibatches' latents (φ of the critic pass, before its
    # step: docs/model-free.md, "One update path"); line 37: targets (TD3: delayed).
    ref.updates = 1
    ref.policy_step(torch.cat([phi.detach(), latent.latent]), a_all, y_all)

    for (name, got), (_, want) in zip(learner.state_dict().items(), ref.state_dict().items(), strict=True):
        torch.testing.assert_close(got, want, atol=1e-6, rtol=1e-5, msg=name)


def test_mve_target_expands_h_model_steps() -> None:
    config = load_config("default", ["net.conv_channels=4,4,4", *LITERAL])
    world = LocalWorldModels(config.dual, 32, 1, regions=False, readings=resolve(config.dual))
    bank = world.bank
    for name in ("w1", "b1", "wm", "wr"):
        bank.params[name].zero_()
    constant = torch.rand(32)
    bank.params["bm"][0] = constant
    bank.params["br"][0] = 0.3
    torch.manual_seed(0)
    mve = make_learner(config.net, config.agent, SPEC)
    mve.value_expansion = ValueExpansion(bank, horizon=2)
    plain = make_learner(config.net, config.agent, SPEC)
    plain.load_state_dict(mve.state_dict())
    plain.value_expansion = ValueExpansion(bank, horizon=0)
    learner_alone = make_learner(config.net, config.agent, SPEC)
    learner_alone.load_state_dict(mve.state_dict())
    reward, next_latent = torch.tensor([0.5, -1.0]), torch.rand(2, 32)
    terminated = torch.tensor([0.0, 1.0])
    gamma = config.agent.gamma
    with torch.no_grad():
        tail = mve.target_critic(constant[None], mve.target_actor(constant[None]))[0]
        expected = reward + gamma * (1 - terminated) * (0.3 + gamma * 0.3 + gamma**2 * tail)
        torch.testing.assert_close(mve.td_target(reward, next_latent, terminated), expected)
        torch.testing.assert_close(plain.td_target(reward, next_latent, terminated),
                                   learner_alone.td_target(reward, next_latent, terminated))


def test_world_models_follow_itm_events_and_report_pre_update_error() -> None:
    config = load_config("default", [*LITERAL, "dual.e_max=0.5"])
    world = LocalWorldModels(config.dual, latent_dim=3, action_dim=1,
                             generator=torch.Generator().manual_seed(0), readings=resolve(config.dual))
    a = torch.tensor([0.2])
    assert world.observe_state(torch.zeros(3)) == 0 and world.num_nodes == 2
    before = world.bank.predict(torch.tensor([0]), torch.zeros(1, 3), a[None])
    feedback = world.learn_transition(0, torch.zeros(3), a, 0.5, torch.ones(3))
    expected = world.bank.errors(before.next_latent, before.reward, torch.ones(1, 3), torch.tensor([0.5]))
    assert feedback.error == pytest.approx(float(expected[0]), rel=1e-6)
    scale = config.dual.intrinsic_scale
    assert feedback.intrinsic_reward == pytest.approx(-scale * float(world.lp.learning_progress(0)[0]))
    node = world.observe_state(torch.tensor([3.0, 0.0, 0.0]))
    assert node == 2 and world.num_nodes == 3
    assert world.lp.error_count(2)[0] == 0 and not world.reliable(2)
    assert int(world.bank.steps[2]) == 0


def test_model_batch_option_trains_on_the_node_recent_transitions() -> None:
    config = load_config("default", [*LITERAL, "dual.model_batch=3"])
    world = LocalWorldModels(config.dual, 2, 1, regions=False, generator=torch.Generator().manual_seed(0),
                             readings=resolve(config.dual))
    twin = copy.deepcopy(world.bank)
    samples = [(torch.rand(2), torch.rand(1), float(i), torch.rand(2)) for i in range(4)]
    for s in samples:
        world.learn_transition(0, *s)
    # The twin replays the same schedule: 1, 2, 3, then 3 samples (the newest plus the two before).
    for i in range(4):
        rows = samples[max(0, i - 2): i + 1]
        twin.update(torch.zeros(len(rows), dtype=torch.int64), torch.stack([r[0] for r in rows]),
                    torch.stack([r[1] for r in rows]), torch.stack([r[3] for r in rows]),
                    torch.tensor([r[2] for r in rows]))
    torch.testing.assert_close(world.bank.theta[0], twin.theta[0], atol=1e-6, rtol=0)


def test_agent_state_round_trips_through_weights_only_load() -> None:
    agent = _agent("i2a")
    obs = _obs(4)
    agent.begin_episode(obs)
    for _ in range(20):
        _step(agent, obs)
    buffer = io.BytesIO()
    torch.save({"agent": agent.state_dict(), "replay": agent.replay_state_dict()}, buffer)
    buffer.seek(0)
    saved = torch.load(buffer, weights_only=True)
    clone = _agent("i2a")
    clone.load_state_dict(saved["agent"])
    clone.load_replay_state_dict(saved["replay"])
    clone.begin_episode(obs)
    assert clone.dual.world.num_nodes == agent.dual.world.num_nodes
    assert clone.dual.total_imagined == agent.dual.total_imagined
    for _ in range(5):
        np.testing.assert_allclose(_step(clone, obs), _step(agent, obs), atol=1e-6)


def test_refit_steps_each_nearest_node_once_and_leaves_the_rest_and_lp_alone() -> None:
    config = load_config("default", [*LITERAL, "dual.e_max=0.5"])
    world = LocalWorldModels(config.dual, latent_dim=2, action_dim=1,
                             generator=torch.Generator().manual_seed(0), readings=resolve(config.dual))
    for point in ([0.0, 0.0], [3.0, 0.0], [0.0, 3.0]):
        world.observe_state(torch.tensor(point))
    nodes = world.itm.nearest(torch.tensor([[0.1, 0.0], [2.9, 0.1]]))
    untouched = [n for n in world.itm.alive_ids() if n not in set(nodes.tolist())]
    assert untouched
    theta, lp = world.bank.theta.clone(), world.lp.state_dict()
    phi = torch.tensor([[0.1, 0.0], [2.9, 0.1]])
    action, reward, next_phi = torch.tensor([[0.5], [-0.5]]), torch.tensor([0.0, 1.0]), phi + 0.2
    errors = world.refit(phi, action, reward, next_phi)
    before = world.bank.errors(*_predict_with(world.bank, theta, nodes, phi, action), next_phi, reward)
    torch.testing.assert_close(errors, before)  # pre-update Eq. 8 errors of each sample's nearest node
    assert world.bank.steps[nodes].tolist() == [1, 1]
    torch.testing.assert_close(world.bank.theta[untouched], theta[untouched])
    assert all(torch.equal(v, lp[k]) for k, v in world.lp.state_dict().items())
    for _ in range(200):
        last = world.refit(phi, action, reward, next_phi)
    assert bool((last < 0.5 * errors).all())  # repeated refits fit each node's model to its samples


def _predict_with(bank, theta, nodes, phi, action):
    saved = bank.theta
    bank.theta = theta
    try:
        prediction = bank.predict(torch.as_tensor(nodes), phi, action)
    finally:
        bank.theta = saved
    return prediction.next_latent, prediction.reward


def test_agent_refits_every_n_real_steps_on_its_replay_and_reports_the_drift() -> None:
    agent = _agent("im2c", "dual.refit_every=5", "dual.refit_batch=16")
    obs = _obs(2)
    agent.begin_episode(obs)
    for _ in range(22):
        _step(agent, obs)
    assert len(agent.dual.counters.refit_errors) == 4
    diagnostics = agent.episode_diagnostics()
    assert np.isfinite(diagnostics["dual/refit_error"])
    assert "dual/refit_error" not in _agent("im2c", "dual.refit_every=0").episode_diagnostics()


def test_no_change_error_is_eq8_of_predicting_phi_t_and_zero_reward() -> None:
    agent = _agent("im2c")  # error_norm l2 (default): ‖φ′ − φ‖ + |r|
    first, second = _obs(3), _obs(4)
    agent.begin_episode(first)
    action, _ = agent.act(first, explore=True)
    phi, next_phi = agent.encode(first)[0], agent.encode(second)[0]
    agent.observe(Transition(first, action, 0.5, second, False, False))
    expected = float((next_phi - phi).norm() + 0.5)
    assert agent.dual.counters.naive_errors == [pytest.approx(expected, rel=1e-5)]
    assert agent.episode_diagnostics()["dual/no_change_error"] == pytest.approx(expected, rel=1e-5)


class _CountingModel:
    """An ImaginationModel on a 1-D line: φ′ = φ + 1, reward = φ, terminal once φ′ ≥ 3, a fixed share."""

    def __init__(self, share: float) -> None:
        self._share = share

    def locate(self, phi):
        return np.zeros(phi.shape[0], dtype=np.int64)

    def proceed(self, regions):
        return np.ones(regions.shape[0], dtype=bool)

    def predict(self, regions, phi, action):
        from core.dual.model_bank import ModelPrediction

        nxt = phi + 1.0
        return ModelPrediction(next_latent=nxt, reward=phi[:, 0], done=(nxt[:, 0] >= 3.0).float())

    def share(self, regions):
        return np.full(regions.shape[0], self._share)


def test_learn_time_imagination_follows_the_model_stops_at_termination_and_is_gated() -> None:
    from core.dual.imagination import imagine

    starts = torch.tensor([[0.0], [1.0], [2.5]])
    batch = imagine(starts, _CountingModel(1.0), lambda phi: torch.zeros(phi.shape[0], 1), 5,
                    np.random.default_rng(0), limit=100)
    # 0 → 1 → 2 → 3 (done), 1 → 2 → 3 (done), 2.5 → 3.5 (done): six transitions, three terminal.
    assert batch.latent.shape[0] == 6 and float(batch.done.sum()) == 3.0
    torch.testing.assert_close(batch.next_latent, batch.latent + 1.0)
    assert set(batch.latent[:, 0].tolist()) == {0.0, 1.0, 2.0, 2.5}
    assert imagine(starts, _CountingModel(0.0), lambda phi: torch.zeros(phi.shape[0], 1), 5,
                   np.random.default_rng(0), limit=100) is None
    limited = imagine(starts, _CountingModel(1.0), lambda phi: torch.zeros(phi.shape[0], 1), 5,
                      np.random.default_rng(0), limit=4)
    assert limited.latent.shape[0] == 4


def test_i2a_imagines_at_learn_time_from_the_current_encoder_and_stores_nothing() -> None:
    agent = _agent("i2a", "agent.learning_starts=4")
    obs = _obs(5)
    agent.begin_episode(obs)
    for step in range(30):
        _step(agent, _obs(step % 3))
        agent.update_after_step()
    assert not hasattr(agent.imagination, "replay")  # no B_latent: Alg. 3 line 17 keeps nothing
    agent.dual.world.heldout.trusted[:] = True  # every region trusted: the rollouts run up to D_max steps
    agent.dual.world.heldout.ratio[:] = 0.0  # and every transition passes the gate
    frames = torch.from_numpy(np.stack([_obs(0), _obs(1)]))
    batch = agent.imagination.minibatch(frames)
    with torch.no_grad():
        current = agent.learner.encode(frames)
    assert batch is not None and batch.latent.shape[0] <= agent.config.dual.latent_batch_size
    first_steps = [row for row in batch.latent if any(torch.allclose(row, c, atol=1e-6) for c in current)]
    assert first_steps  # rollouts start at the minibatch's latents under the encoder as it is now
    assert agent.dual.counters.imagined >= batch.latent.shape[0]


def test_imagination_depth_one_starts_every_imagined_transition_at_a_real_state() -> None:
    """``dual.imagination_depth=1``: the imagined states are the minibatch's own latents, only φ̂′ is the
    model's; without it the same trusted regions roll out past the first step."""
    frames = torch.from_numpy(np.stack([_obs(0), _obs(1), _obs(2)]))
    rows = {}
    for depth in (None, 1):
        option = [] if depth is None else [f"dual.imagination_depth={depth}"]
        agent = _agent("i2a", "agent.learning_starts=4", *option)
        agent.begin_episode(_obs(5))
        for step in range(30):
            _step(agent, _obs(step % 3))
            agent.update_after_step()
        agent.dual.world.heldout.trusted[:] = True
        agent.dual.world.heldout.ratio[:] = 0.0
        batch = agent.imagination.minibatch(frames)
        with torch.no_grad():
            current = agent.learner.encode(frames)
        rows[depth] = [any(torch.allclose(row, c, atol=1e-6) for c in current) for row in batch.latent]
    assert all(rows[1]) and len(rows[1]) == 3
    assert not all(rows[None])  # D_max = 6: later steps start at predicted latents


def test_i2a_without_its_planner_is_refused_with_the_fix() -> None:
    with pytest.raises(ConfigError, match=re.escape("--algo im2c --set dual.arbitration=model_free")):
        check_config(load_config("default", ["run.algo=i2a", "run.steps=10", "dual.arbitration=model_free"]))
    check_config(load_config("default", ["run.algo=im2c", "run.steps=10", "dual.arbitration=model_free"]))


@pytest.mark.parametrize(("overrides", "fix"), [
    (["dual.e_max_relative=1.0"], "dual.regions=released"),
    (["dual.model_batch=1"], "dual.model_memory=0"),
    (["dual.model_batch=16", "dual.model_memory=4"], r"or >= 15"),
])
def test_dual_settings_that_make_no_sense_together_are_refused(overrides: list[str], fix: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(fix)):
        check_config(load_config("default", ["run.steps=10", *overrides]))


@pytest.mark.parametrize("algo", ["im2c", "i2a"])
def test_the_learners_value_joins_plans_only_after_a_positive_extrinsic_reward(algo: str) -> None:
    """Item 24 (docs/dual-system.md): a planner reading with ``terminal`` plans without the learner's value
    while every reward seen is a cost (≤ 0) and with it from the first positive reward on; a checkpoint keeps
    which."""
    from core.dual.planning import TerminalValue

    agent = _agent(algo, *LITERAL, "agent.ac=sac", "dual.planner=value")
    reads = []
    value_fn = agent.dual.value.value

    def counted(latent: np.ndarray) -> tuple[float, np.ndarray]:
        reads.append(latent)
        return value_fn(latent)

    agent.dual.value = TerminalValue(counted, agent.dual.value.discount)
    obs = _obs(5)
    agent.begin_episode(obs)
    for _ in range(60):
        _step(agent, obs, reward=-0.25)
    planned = agent.dual.total_mb_decisions
    assert planned > 0 and reads == [] and agent.dual.terminal_value() is None
    _step(agent, obs, reward=1.0)
    assert agent.dual.terminal_value() is agent.dual.value
    before = agent.dual.total_mb_decisions
    for _ in range(20):
        _step(agent, obs, reward=-0.25)  # costs again: the gate stays open
    assert len(reads) == agent.dual.total_mb_decisions - before > 0  # one read per plan
    clone = _agent(algo, *LITERAL, "agent.ac=sac", "dual.planner=value")
    assert clone.dual.terminal_value() is None
    clone.load_state_dict(agent.state_dict())
    assert clone.dual.rewarded and clone.dual.terminal_value() is clone.dual.value
