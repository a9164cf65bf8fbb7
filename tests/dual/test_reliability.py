"""Held-out reliability (core/dual/reliability.py): the verdict rule, the held-out routing, the snapshots, and
what the world and the agents read from it (trust, the progress r_int, the imagination gate)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from core.config import load_config
from core.dual.readings import HeldOut, Intrinsic, resolve
from core.dual.reliability import judge, share_from_ratio
from core.dual.world_models import LocalWorldModels


def _verdict(now: float, before: float, no_change: float = 1.0, jitter: float = 0.05,
             comparable: bool = True):
    rng = np.random.default_rng(0)
    difficulty = np.abs(1.0 + 0.5 * rng.normal(size=(1, 48)))
    errors_now = now * difficulty * (1.0 + jitter * rng.normal(size=(1, 48)))
    errors_before = before * difficulty * (1.0 + jitter * rng.normal(size=(1, 48)))
    errors_no_change = no_change * np.abs(1.0 + 0.5 * rng.normal(size=(1, 48)))
    return judge(errors_now, errors_before, errors_no_change, np.ones((1, 48), dtype=bool), z=3.0,
                 accurate_ratio=0.5, min_count=24, comparable=np.array([comparable]))


def test_accurate_and_improving_models_are_trusted_worsening_and_unlearnable_ones_are_not() -> None:
    assert _verdict(now=0.2, before=0.2).trusted[0]  # accurate, flat
    assert _verdict(now=0.7, before=0.9).trusted[0]  # improving, not yet accurate
    assert not _verdict(now=0.8, before=0.8).trusted[0]  # flat well above the accurate level
    assert not _verdict(now=0.4, before=0.25).trusted[0]  # accurate but getting worse
    assert not _verdict(now=1.2, before=1.5).trusted[0]  # improving but still worse than "nothing changes"
    young = _verdict(now=0.7, before=0.9, comparable=False)  # no snapshot two rotations back yet
    assert not young.trusted[0] and young.progress[0] == 0.0


def test_progress_is_the_paired_mean_decrease_and_the_recent_window_sets_the_ratio() -> None:
    verdict = _verdict(now=0.6, before=0.8)
    assert verdict.progress[0] == pytest.approx(0.2 * 1.1, rel=0.25)  # 0.2 × E|1 + 0.5ε| ≈ 0.22
    assert verdict.standard_error[0] < 0.1 * verdict.progress[0]
    ones = np.ones((1, 48))
    recent = (np.full((1, 40), 0.9), np.ones((1, 40)), np.ones((1, 40), dtype=bool))  # just got worse
    shifted = judge(0.2 * ones, 0.2 * ones, ones, np.ones((1, 48), dtype=bool), 3.0, 0.5, 24, recent=recent)
    assert shifted.ratio[0] == pytest.approx(0.9) and not shifted.trusted[0]
    np.testing.assert_allclose(share_from_ratio(np.array([0.0, 0.25, 1.0, 3.0])), [1.0, 0.75, 0.0, 0.0])
    # dual.imagination_max_ratio = 0.5: nothing from a model at or above half the no-change error.
    np.testing.assert_allclose(share_from_ratio(np.array([0.0, 0.25, 0.5, 0.9]), 0.5), [1.0, 0.5, 0.0, 0.0])


def _world(*overrides: str) -> LocalWorldModels:
    dual = load_config("default", list(overrides)).dual
    readings = dataclasses.replace(resolve(dual), held_out=HeldOut(size=8, lag=5))
    return LocalWorldModels(dual, 2, 1, regions=False, generator=torch.Generator().manual_seed(0),
                            readings=readings)


def test_every_kth_transition_is_held_out_and_never_trained_on() -> None:
    world = _world()
    heldout = world.heldout
    g = torch.Generator().manual_seed(1)
    samples = [(torch.rand(2, generator=g), torch.rand(1, generator=g)) for _ in range(8)]
    for phi, action in samples:
        world.learn_transition(0, phi, action, 0.0, phi + 0.1)
    assert heldout.written[0] == 2  # the 4th and the 8th
    torch.testing.assert_close(heldout.latent[0, :2], torch.stack([samples[3][0], samples[7][0]]))
    stored = world._memory.get(0)[0]
    assert stored.shape[0] == 6 and not any(torch.equal(row, samples[3][0]) for row in stored)
    assert heldout.recent_count[0] == 8  # every new transition's pre-update error is in the recent window


def test_snapshots_rotate_every_lag_updates_and_progress_waits_for_two() -> None:
    world = _world()
    heldout = world.heldout
    g = torch.Generator().manual_seed(2)
    for step in range(60):
        phi = torch.rand(2, generator=g)
        world.learn_transition(0, phi, torch.rand(1, generator=g), 0.0, phi + 0.3 * phi.sum())
        if step == 8:
            assert heldout.taken[0] == 1 and heldout.progress[0] == 0.0
    assert heldout.taken[0] == heldout.updates[0] // 5 >= 8
    assert heldout.progress[0] != 0.0 and np.isfinite(heldout.ratio[0])


def test_repaired_intrinsic_reward_is_the_progress_of_the_region_the_action_led_into() -> None:
    dual = load_config("default", ["dual.e_max=0.5"]).dual
    world = LocalWorldModels(dual, 2, 1, generator=torch.Generator().manual_seed(0), readings=resolve(dual))
    world.scale.warmup = 1
    for point in ([0.0, 0.0], [3.0, 0.0], [0.0, 3.0], [0.1, 0.0]):
        world.observe_state(torch.tensor(point))
    here = world.nearest(torch.tensor([0.0, 0.0]))
    there = world.nearest(torch.tensor([3.0, 0.0]))
    assert here != there
    world.heldout.progress[[here, there]] = [0.0, 0.4]
    unit = world.unit.scale
    feedback = world.learn_transition(here, torch.tensor([0.0, 0.0]), torch.tensor([1.0]), 0.0,
                                      torch.tensor([3.0, 0.0]))
    assert feedback.intrinsic_reward == pytest.approx(dual.intrinsic_scale * 0.4 / unit, rel=1e-6)
    source = Intrinsic(signal="progress", region="source")  # no reading: repaired signal, paper's region
    world.readings = dataclasses.replace(world.readings, intrinsic=source)
    assert world.intrinsic_reward(here, torch.tensor([3.0, 0.0])) == pytest.approx(0.0)


def test_centred_paper_intrinsic_reward_is_the_paper_signal_minus_its_mean_over_live_regions() -> None:
    """``dual.intrinsic = paper_centred`` (issue 29's control): r_int(n) = −c·LP(n) − mean_m(−c·LP(m)) over
    the live regions m, so its mean over them is 0 and only its dependence on the region is left."""
    overrides = ["dual.e_max=0.5", "dual.intrinsic=paper_centred", "dual.reliability=released",
                 "dual.intrinsic_scale=1.0", "dual.lp_sigma=2", "dual.lp_window=2"]
    dual = load_config("default", overrides).dual
    world = LocalWorldModels(dual, 2, 1, generator=torch.Generator().manual_seed(0), readings=resolve(dual))
    world.scale.warmup = 1
    g = torch.Generator().manual_seed(3)
    for point in ([0.0, 0.0], [3.0, 0.0], [0.0, 3.0]):
        world.observe_state(torch.tensor(point))
    regions = world.alive_regions()
    for step in range(40):  # errors that shrink in one region and grow in another give LPs of both signs
        node = int(regions[step % len(regions)])
        target = torch.rand(2, generator=g) * (0.1 if node == regions[0] else 1.0 + step / 10)
        world.learn_transition(node, torch.rand(2, generator=g), torch.rand(1, generator=g), 0.0, target)
    paper = world.lp.intrinsic_reward(regions)
    assert np.ptp(paper) > 0  # the regions differ
    centred = np.array([world.intrinsic_reward(int(n), torch.zeros(2)) for n in regions])
    np.testing.assert_allclose(centred, paper - paper.mean(), atol=1e-12)
    assert abs(centred.mean()) < 1e-12



def test_novelty_is_the_error_ratio_to_no_change_clipped_and_unknown_counts_as_novel() -> None:
    world = _world("dual.planner=novelty")
    held = world.heldout
    held.ensure_capacity(3)
    held.ratio[:3] = [0.3, 1.4, np.nan]
    np.testing.assert_allclose(held.relative_error([0, 1, 2]), [0.3, 1.0, 1.0])
    assert world.aim_goal("novelty") is None  # no map: a global model has no regions to aim at
