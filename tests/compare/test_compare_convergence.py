"""Observed order and Richardson extrapolation on manufactured sequences."""

import numpy as np
import pytest

from compare.analysis import CostPoint, dominance_bounds, matched_ratios, time_at_error
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


def test_richardson_rejects_differences_that_do_not_shrink():
    # Equal differences (the dam break's region volume counts cells: its peaks at a/32,
    # a/64, a/128 differ by the same amount) give order 0 and no limit; growing ones a
    # negative order.
    h = np.array([0.4, 0.2, 0.1])
    for values in ([1.0, 0.9, 0.8], [1.0, 0.9, 0.7]):
        with pytest.raises(CompareError, match="do not shrink"):
            richardson(h, np.array(values))


def test_wall_time_at_matched_error_is_loglog_interpolated():
    curve = [CostPoint("interFoam", 1, 1.0, 0.1), CostPoint("interFoam", 2, 10.0, 0.01)]
    assert time_at_error(curve, 10**-1.5) == pytest.approx(10**0.5)
    assert time_at_error(curve, 0.5) is None
    ours = [CostPoint("IQ-MPM", 1, 2.0, 10**-1.5)]
    ratios = matched_ratios(ours, curve)
    assert len(ratios) == 1
    err, t_ours, t_foam = ratios[0]
    assert t_foam / t_ours == pytest.approx(10**0.5 / 2.0)


def test_dominance_bound_where_the_error_ranges_do_not_overlap():
    """dam_break's front, as measured: IQ-MPM's coarsest run is more accurate than
    interFoam's most accurate one and cheaper, so no error is matched by interpolation; the
    ratio at matched error is then at least t(interFoam L2) / t(IQ-MPM L1)."""
    ours = [CostPoint("IQ-MPM", 1, 2.1, 0.0033), CostPoint("IQ-MPM", 2, 29.2, 0.0010)]
    foam = [CostPoint("interFoam", 1, 3.3, 0.0124), CostPoint("interFoam", 2, 16.3, 0.0098)]
    assert matched_ratios(ours, foam) == []
    bounds = dominance_bounds(ours, foam)
    assert len(bounds) == 1
    assert (bounds[0].fast.level, bounds[0].slow.level) == (1, 2)
    assert bounds[0].ratio == pytest.approx(16.3 / 2.1)
    # The other way round (interFoam dominates): a bound on that side.
    swapped = [CostPoint("IQ-MPM", p.level, p.wall_time, p.error) for p in foam]
    back = [CostPoint("interFoam", p.level, p.wall_time, p.error) for p in ours]
    assert [b.fast.solver for b in dominance_bounds(swapped, back)] == ["interFoam"]
    # More accurate but dearer than the other's best run: no bound either way.
    dear = [CostPoint("IQ-MPM", 1, 20.0, 0.0033)]
    assert dominance_bounds(dear, foam) == []
