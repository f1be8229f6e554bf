"""Observed order and Richardson extrapolation on manufactured sequences."""

import numpy as np
import pytest

from compare.analysis import CostPoint, matched_ratios, time_at_error
from compare.convergence import observed_order, richardson
from compare.io import CompareError


def test_observed_order_of_4h2_is_2():
    h = np.array([0.1, 0.05, 0.025, 0.0125])
    o = observed_order(h, 4 * h**2)
    assert o.order == pytest.approx(2.0)
    assert o.pairwise == pytest.approx((2.0, 2.0, 2.0))
    assert o.constant == pytest.approx(4.0)


def test_observed_order_ignores_level_order_and_sign():
    h = np.array([0.025, 0.1, 0.05])
    assert observed_order(h, -3 * h).order == pytest.approx(1.0)


def test_observed_order_needs_two_levels():
    with pytest.raises(CompareError, match="two levels"):
        observed_order(np.array([0.1]), np.array([0.2]))


def test_richardson_constant_ratio():
    h = np.array([0.4, 0.2, 0.1])
    r = richardson(h, 1.0 + 3.0 * h**2)
    assert r.order == pytest.approx(2.0)
    assert r.extrapolated == pytest.approx(1.0)
    assert r.errors == pytest.approx(tuple(3.0 * h**2))


def test_richardson_non_constant_ratio_and_extra_levels():
    h = np.array([0.5, 0.3, 0.2, 0.1])
    r = richardson(h, 2.0 - 0.5 * h**1.5)
    assert r.order == pytest.approx(1.5, rel=1e-6)
    assert r.extrapolated == pytest.approx(2.0, rel=1e-9)


def test_richardson_rejects_oscillation():
    with pytest.raises(CompareError, match="oscillatory"):
        richardson(np.array([0.4, 0.2, 0.1]), np.array([1.0, 1.2, 1.1]))


def test_wall_time_at_matched_error_is_loglog_interpolated():
    curve = [CostPoint("interFoam", 1, 1.0, 0.1), CostPoint("interFoam", 2, 10.0, 0.01)]
    assert time_at_error(curve, 10**-1.5) == pytest.approx(10**0.5)
    assert time_at_error(curve, 0.5) is None
    ours = [CostPoint("IQ-MPM", 1, 2.0, 10**-1.5)]
    ratios = matched_ratios(ours, curve)
    assert len(ratios) == 1
    err, t_ours, t_foam = ratios[0]
    assert t_foam / t_ours == pytest.approx(10**0.5 / 2.0)
