"""AuC, Final Performance and smoothing on hand-made curves (Section 4.1.2; core/runs/metrics.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.runs.metrics import area_under_curve, final_performance, smooth


def test_auc_of_constant_and_ramp_curves():
    assert area_under_curve([1.0] * 10) == pytest.approx(1.0)
    assert area_under_curve([0.0] * 10) == pytest.approx(0.0)
    ramp = np.linspace(0.0, 1.0, 101)  # learning from 0 to 1 linearly: half the area under reward 1
    assert area_under_curve(ramp) == pytest.approx(0.5)
    assert area_under_curve([-1.0, 1.0, 0.5, 0.5]) == pytest.approx(0.25)


def test_auc_from_minus_one_baseline():
    assert area_under_curve([-1.0] * 4, baseline=-1.0) == pytest.approx(0.0)
    assert area_under_curve([1.0] * 4, baseline=-1.0) == pytest.approx(1.0)
    assert area_under_curve([-1.0, 1.0], baseline=-1.0) == pytest.approx(0.5)
    with pytest.raises(ValueError):
        area_under_curve([0.0], baseline=1.0)


def test_final_performance_uses_the_last_500_episodes():
    curve = [-1.0] * 1000 + [0.5] * 500
    assert final_performance(curve) == pytest.approx(0.5)
    assert final_performance([0.0, 1.0, 2.0]) == pytest.approx(1.0)  # fewer than 500: all
    assert final_performance([1.0, 2.0, 3.0, 4.0], last=2) == pytest.approx(3.5)
    assert math.isnan(final_performance([])) and math.isnan(area_under_curve([]))


def test_smoothing_is_a_trailing_window_mean_of_same_length():
    values = [0.0, 2.0, 4.0, 6.0, 8.0]
    assert smooth(values, 2).tolist() == pytest.approx([0.0, 1.0, 3.0, 5.0, 7.0])
    assert smooth(values, 10).tolist() == pytest.approx([0.0, 1.0, 2.0, 3.0, 4.0])
    assert smooth(values, 1).tolist() == values
    assert smooth([], 5).size == 0
