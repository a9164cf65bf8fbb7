"""Learning progress (Eq. 8-9): sign, windowing, warm-up readings, normalisation, intrinsic reward."""

from __future__ import annotations

import numpy as np
import pytest

from core.dual.learning_progress import LearningProgress


def _feed(lp: LearningProgress, node: int, errors: list[float]) -> None:
    for e in errors:
        lp.record([node], [e])


def test_paper_reading_unreliable_until_history_is_full() -> None:
    lp = LearningProgress(window=2, history=3, warmup="unreliable")
    _feed(lp, 0, [4.0, 4.0, 2.0])
    # Only 3 window means (need W + 1 = 4): LP undefined, node unreliable, no intrinsic reward.
    assert np.isnan(lp.learning_progress(0)[0])
    assert not lp.reliable(0)[0]
    assert lp.intrinsic_reward(0)[0] == 0.0
    _feed(lp, 0, [2.0])
    # Window means: 4, 4, 3, 2 → LP = ⟨e⟩_{t−3} − ⟨e⟩_t = 4 − 2 = 2 (errors falling: progress).
    assert lp.learning_progress(0)[0] == pytest.approx(2.0)
    assert lp.reliable(0)[0]
    assert lp.intrinsic_reward(0)[0] == pytest.approx(-2.0)


def test_rising_errors_give_negative_lp_and_positive_intrinsic_reward() -> None:
    lp = LearningProgress(window=1, history=2, scale=0.5)
    _feed(lp, 3, [1.0, 2.0, 5.0])
    assert lp.learning_progress(3)[0] == pytest.approx(1.0 - 5.0)
    assert not lp.reliable(3)[0]
    assert lp.intrinsic_reward(3)[0] == pytest.approx(0.5 * 4.0)


def test_window_keeps_only_sigma_recent_errors() -> None:
    lp = LearningProgress(window=2, history=1)
    _feed(lp, 0, [10.0, 0.0, 0.0])
    # Means of the last ≤ 2 errors: 10, 5, 0; the history keeps W + 1 = 2 of them: (5, 0).
    assert lp.window_mean(0)[0] == pytest.approx(0.0)
    assert lp.learning_progress(0)[0] == pytest.approx(5.0)
    _feed(lp, 0, [4.0])
    # Window (0, 4) → mean 2; history (0, 2) → LP = −2.
    assert lp.learning_progress(0)[0] == pytest.approx(-2.0)


def test_released_reading_new_node_starts_negative() -> None:
    lp = LearningProgress(window=40, history=20, warmup="zero_oldest", normalise=True)
    _feed(lp, 5, [0.8])
    # Oldest mean counts as 0 while only one exists: (0 − 0.8) / 0.8 = −1 → model-free.
    assert lp.learning_progress(5)[0] == pytest.approx(-1.0)
    assert not lp.reliable(5)[0]
    _feed(lp, 5, [0.4])
    # Means 0.8, 0.6: LP = (0.8 − 0.6) / max(0.8, 0.6).
    assert lp.learning_progress(5)[0] == pytest.approx(0.2 / 0.8)
    assert lp.reliable(5)[0]


def test_normalised_lp_is_scale_free() -> None:
    stream = [3.0, 2.5, 2.0, 1.0, 1.5, 0.5]
    a = LearningProgress(window=2, history=3, normalise=True)
    b = LearningProgress(window=2, history=3, normalise=True)
    _feed(a, 0, stream)
    _feed(b, 0, [100.0 * e for e in stream])
    assert a.learning_progress(0)[0] == pytest.approx(b.learning_progress(0)[0])


def test_nodes_are_independent_and_batch_record_equals_sequential() -> None:
    rng = np.random.default_rng(0)
    ids = rng.integers(0, 5, size=200)
    errs = rng.random(200)
    batched = LearningProgress(window=4, history=3, initial_capacity=2)
    sequential = LearningProgress(window=4, history=3, initial_capacity=2)
    batched.record(ids, errs)
    for node, e in zip(ids, errs, strict=True):
        sequential.record([node], [e])
    np.testing.assert_allclose(batched.learning_progress(range(5)), sequential.learning_progress(range(5)))
    np.testing.assert_allclose(batched.window_mean(range(5)), sequential.window_mean(range(5)))
    assert batched.capacity >= 5


def test_reset_forgets_a_reused_slot() -> None:
    lp = LearningProgress(window=1, history=1)
    _feed(lp, 2, [3.0, 1.0])
    assert lp.reliable(2)[0]
    lp.reset_nodes([2])
    assert np.isnan(lp.learning_progress(2)[0])


def test_state_dict_round_trip() -> None:
    lp = LearningProgress(window=3, history=2)
    lp.record([0, 1, 0, 1, 0, 0], [1.0, 2.0, 0.5, 3.0, 0.2, 0.1])
    other = LearningProgress(window=3, history=2)
    other.load_state_dict(lp.state_dict())
    np.testing.assert_allclose(other.learning_progress([0, 1]), lp.learning_progress([0, 1]))


def test_bad_inputs_raise() -> None:
    with pytest.raises(ValueError):
        LearningProgress(window=0)
    with pytest.raises(ValueError):
        LearningProgress(warmup="eager")
    lp = LearningProgress()
    with pytest.raises(ValueError, match="non-finite"):
        lp.record([0], [float("nan")])
    with pytest.raises(ValueError, match="node ids"):
        lp.record([0, 1], [1.0])
