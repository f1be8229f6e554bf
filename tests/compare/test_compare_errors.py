"""Error measures on synthetic series with known answers."""

import math

import numpy as np
import pytest

from compare.errors import Series, interval_means, on_common_times, relative_error, series_error
from compare.io import CompareError


def test_relative_l2_of_scaled_series_is_the_scale():
    t = np.linspace(0.0, 1.0, 101)
    ref = Series.of(t, 1.0 + np.sin(3 * t), "ref")
    ours = Series.of(t, 1.1 * (1.0 + np.sin(3 * t)), "ours")
    e = series_error(ours, ref)
    assert e.rel_l2 == pytest.approx(0.1, rel=1e-12)
    assert e.peak_rel_error == pytest.approx(0.1, rel=1e-12)
    assert e.peak_time_error == pytest.approx(0.0)


def test_relative_l2_against_constant_offset():
    t = np.linspace(0.0, 2.0, 11)
    e = series_error(Series.of(t, np.full_like(t, 3.0)), Series.of(t, np.full_like(t, 2.0)))
    assert e.rel_l2 == pytest.approx(0.5)
    assert e.rms == pytest.approx(1.0)


def test_finer_series_is_interpolated_onto_coarser_times():
    t_fine = np.linspace(0.0, 1.0, 1001)
    t_coarse = np.linspace(0.0, 1.0, 11)
    ours = Series.of(t_fine, 2.0 * t_fine + 1.0)  # linear: interpolation is exact
    ref = Series.of(t_coarse, 2.0 * t_coarse + 1.0)
    t, y, r = on_common_times(ours, ref)
    np.testing.assert_allclose(t, t_coarse)
    np.testing.assert_allclose(y, r)
    assert series_error(ours, ref).rel_l2 == pytest.approx(0.0, abs=1e-12)
    # and the other way round: the reference is the finer one
    t2, y2, r2 = on_common_times(Series.of(t_coarse, t_coarse**2), Series.of(t_fine, t_fine**2))
    np.testing.assert_allclose(t2, t_coarse)
    np.testing.assert_allclose(r2, t_coarse**2, atol=1e-6)


def test_common_window_is_the_overlap():
    ours = Series.of(np.linspace(0.0, 2.0, 21), np.ones(21))
    ref = Series.of(np.linspace(0.5, 3.0, 26), np.ones(26))
    e = series_error(ours, ref)
    assert e.window == (pytest.approx(0.5), pytest.approx(2.0))
    assert e.n_points == 16  # ours is coarser (16 samples in [0.5, 2] vs 16): ties -> ref
    t, _, _ = on_common_times(ours, ref)
    assert t[0] == pytest.approx(0.5) and t[-1] == pytest.approx(2.0)


def test_peak_value_and_time_errors():
    t = np.linspace(0.0, 1.0, 1001)
    ref = Series.of(t, np.exp(-((t - 0.40) / 0.05) ** 2))
    ours = Series.of(t, 1.2 * np.exp(-((t - 0.45) / 0.05) ** 2))
    e = series_error(ours, ref)
    assert e.peak_ref == pytest.approx(1.0)
    assert e.peak_rel_error == pytest.approx(0.2, rel=1e-9)
    assert e.t_peak_ref == pytest.approx(0.40)
    assert e.peak_time_error == pytest.approx(0.05, abs=1e-9)


def test_negative_peak_keeps_sign():
    t = np.linspace(0, 1, 11)
    e = series_error(Series.of(t, -2 * t), Series.of(t, -t))
    assert e.peak_ours == -2.0 and e.peak_ref == -1.0
    assert e.peak_rel_error == pytest.approx(-1.0)


def test_nan_samples_are_dropped():
    t = np.linspace(0, 1, 11)
    y = t + 1
    y_nan = y.copy()
    y_nan[3] = np.nan
    assert series_error(Series.of(t, y_nan), Series.of(t, y)).rel_l2 == pytest.approx(0.0)


def test_disjoint_series_raise_clear_error():
    with pytest.raises(CompareError, match="do not overlap"):
        series_error(Series.of([0.0, 1.0], [1, 1], "a"), Series.of([2.0, 3.0], [1, 1], "b"))


def test_scalar_relative_error():
    assert relative_error(3.386 * 1.05, 3.386) == pytest.approx(0.05)
    assert relative_error(-1.1, -1.0) == pytest.approx(-0.1)
    assert math.isnan(relative_error(1.0, 0.0))


def test_draft_scalar_is_level_minus_bottom_over_the_tail():
    """The floating benchmarks' draft: still-water level - (centre - 0.05), mean over the last 40 %."""
    from pathlib import Path

    from compare.reducers import scalar_value
    from compare.io import Metrics, Run
    from compare.registry import lookup

    spec = next(s for s in lookup("floating_block").scalars if s.name == "equilibrium_draft")
    t = np.linspace(0.0, 5.0, 501)
    # A decaying heave about a centre 0.496 m under a level of 0.5025 m: draft 0.0565 m.
    centre = 0.496 + 0.01 * np.exp(-t) * np.cos(2 * np.pi * t / 0.8)
    level = np.full_like(t, 0.5025)
    level[t < 2.0] = 0.6  # only the tail counts
    metrics = Metrics(Path("synthetic"), t, {"com_y": centre, "water_level": level})
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, metrics)
    tail = t >= 3.0
    expected = float(np.mean(level[tail] - centre[tail] + 0.05))
    assert scalar_value(run, spec) == pytest.approx(expected, rel=1e-12)
    assert expected == pytest.approx(0.0565, abs=1e-4)
    assert spec.reference == 0.05
    no_level = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"com_y": centre}))
    assert scalar_value(no_level, spec) is None


def test_decay_ratio_of_a_damped_oscillation():
    """The floating benchmarks' heave_decay / roll_decay: amplitude ratio per period of the
    damped sinusoid fitted over the first two periods, with its uncertainty, and
    heave_period / roll_period over the same first two periods.

    For y = eq + A exp(-a t) cos(w t) it is exp(-a T) (T = 2 pi / w) exactly. Noise of 0.5 %
    of A must leave it within its own uncertainty, and an uncertainty that covers the truth
    must also be small (below 1 %: the estimate resolves the decay); a run with fewer than two
    periods gives NaN, and a growing oscillation a ratio above 1. The half-cycles (the first
    guess of the fitted periods) are not split by the jitter.
    """
    from pathlib import Path

    from compare.reducers import half_cycle_amplitudes, reduce_series_u, scalar_value
    from compare.io import Metrics, Run
    from compare.registry import lookup

    spec = next(s for s in lookup("floating_block").scalars if s.name == "heave_decay")
    period_spec = next(s for s in lookup("floating_block").scalars if s.name == "heave_period")
    a, period = 0.2, 1.0
    exact = math.exp(-a * period)
    t = np.linspace(0.0, 20.0, 20001)
    rng = np.random.default_rng(3)
    centre = 0.504 + 0.016 * np.exp(-a * t) * np.cos(2 * np.pi * t / period)
    noisy = centre + 0.005 * 0.016 * rng.standard_normal(t.size)
    for y, rel in ((centre, 1e-6), (noisy, 0.01)):
        run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"com_y": y}))
        assert scalar_value(run, spec) == pytest.approx(exact, rel=rel)
        assert scalar_value(run, period_spec) == pytest.approx(period, rel=max(rel, 1e-4))
    value, uncertainty = reduce_series_u(t, noisy, "decay")
    assert abs(value - exact) <= uncertainty < 0.01 * exact
    # The uncertainty is an expanded (k = 2) standard error: over 20 noise realisations at
    # 5 % of A it covers the truth about 19 times in 20, and half of it matches the spread.
    short = t <= 5.0
    values, halves = [], []
    for seed in range(20):
        y = centre[short] + 0.05 * 0.016 * np.random.default_rng(100 + seed).standard_normal(int(short.sum()))
        v, u = reduce_series_u(t[short], y, "decay")
        values.append(v)
        halves.append(u / 2)
    covered = sum(abs(v - exact) <= 2 * h for v, h in zip(values, halves))
    assert covered >= 16
    assert np.mean(halves) == pytest.approx(np.std(values), rel=0.5)
    # Late sloshing at another period (here 0.6 s, after 4 s) does not change the early
    # period or decay; the mean over the whole run would.
    sloshing = centre + np.where(t > 4.0, 0.004 * np.sin(2 * np.pi * t / 0.6), 0.0)
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"com_y": sloshing}))
    assert scalar_value(run, period_spec) == pytest.approx(period, rel=0.003)
    assert scalar_value(run, spec) == pytest.approx(exact, rel=0.003)
    # Five periods from a crest cross the equilibrium ten times: eleven half-cycles, the
    # amplitudes falling; with the jitter, the same count (no crossing is split).
    early = t < 5.0
    for y in (centre, noisy):
        amplitudes = half_cycle_amplitudes(t[early], y[early])
        assert len(amplitudes) == 11
        assert np.all(np.diff(amplitudes) < 0)
    short = t < 1.2
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t[short], {"com_y": centre[short]}))
    assert math.isnan(scalar_value(run, spec))
    growing = 0.504 + 0.016 * np.exp(0.1 * t) * np.cos(2 * np.pi * t / period)
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"com_y": growing}))
    assert scalar_value(run, spec) > 1.0


def test_obstacle_force_peak_and_impulses():
    """dam_break_obstacle's scalars: the largest 10 ms mean and the impulses of the force.

    An impact pulse F = 170 sin^2(pi (t - 0.1) / 0.1) on 0.1-0.2 s has a 10 ms mean peak of
    170 (1/2 + sin(pi/10) / (2 pi/10)) and an impulse of 8.5 N s/m. Sampled every 2 ms (interFoam's output) the window mean must not undercount; a
    single-step spike of 800 N/m lasting 0.4 ms adds only its 0.32 N s/m / 0.01 s to a mean.
    """
    from pathlib import Path

    from compare.reducers import scalar_value
    from compare.io import Metrics, Run
    from compare.registry import lookup

    scalars = {s.name: s for s in lookup("dam_break_obstacle").scalars}

    def pulse(t):
        return np.where((t > 0.1) & (t < 0.2), 170 * np.sin(np.pi * (t - 0.1) / 0.1) ** 2, 0.0)

    exact_peak = 170 * (0.5 + math.sin(math.pi / 10) / (2 * math.pi / 10))
    for spacing in (0.0004, 0.002):
        t = np.arange(0.0, 1.0 + spacing / 2, spacing)
        run = Run(Path("synthetic"), "iqmpm", {"status": "ok"},
                  Metrics(Path("synthetic"), t, {"obstacle_force_x": pulse(t)}))
        assert scalar_value(run, scalars["force_peak_10ms"]) == pytest.approx(exact_peak, rel=2e-3)
        assert scalar_value(run, scalars["impulse"]) == pytest.approx(8.5, rel=2e-3)
        assert scalar_value(run, scalars["impulse_to_0.3s"]) == pytest.approx(8.5, rel=2e-3)
    t = np.arange(0.0, 1.0002, 0.0004)
    spiky = pulse(t)
    spiky[np.argmin(np.abs(t - 0.5))] = 800.0
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"obstacle_force_x": spiky}))
    assert scalar_value(run, scalars["force_peak_10ms"]) == pytest.approx(exact_peak, rel=2e-3)  # the spike: 32 N/m
    late = Run(Path("synthetic"), "iqmpm", {"status": "ok"},
               Metrics(Path("synthetic"), t, {"obstacle_force_x": np.where(t > 0.3, 10.0, 0.0)}))
    assert scalar_value(late, scalars["impulse_to_0.3s"]) == pytest.approx(0.0, abs=1e-3)
    assert scalar_value(late, scalars["impulse"]) == pytest.approx(7.0, rel=1e-3)


def _steps_with_a_packet(dt: float, force: float, impulse: float, at: float) -> Series:
    """A steady per-step force with the impulse ``impulse`` delivered in the one step that
    ends at ``at``: its value there is force + impulse / dt."""
    t = np.arange(0.0, 1.0 + dt / 2, dt)
    y = np.full_like(t, force)
    y[int(round(at / dt))] += impulse / dt
    return Series.of(t, y)


def test_interval_means_carry_an_impulse_packet_whatever_the_step():
    # The same impulse in one step of 0.1 ms or of 0.4 ms: the raw step value differs 4x,
    # the mean over the reference's 2 ms interval holding it does not.
    samples = np.arange(0.002, 0.999, 0.002)
    means = [interval_means(_steps_with_a_packet(dt, 50.0, 0.03, 0.3004), samples) for dt in (1e-4, 4e-4)]
    for m in means:
        hit = np.argmin(np.abs(m.t - 0.3))  # the interval [0.299, 0.301] holds the packet's step
        assert m.y[hit] == pytest.approx(50.0 + 0.03 / 0.002, rel=1e-9)
        assert np.delete(m.y, hit) == pytest.approx(50.0, rel=1e-9)
    np.testing.assert_allclose(means[0].y, means[1].y, rtol=1e-9)


def test_interval_means_of_a_piecewise_constant_series_are_exact():
    # Values held over each step: the mean over any interval is the exact time average.
    t = np.linspace(0.0, 1.0, 401)
    y = np.sin(7 * t)
    samples = np.array([0.1, 0.25, 0.4, 0.7])  # uneven: halfway to the neighbours
    m = interval_means(Series.of(t, y), samples)
    edges = [(0.025, 0.175), (0.175, 0.325), (0.325, 0.55), (0.55, 0.85)]
    fine = np.linspace(0.0, 1.0, 400001)
    held = y[np.minimum(np.searchsorted(t, fine, side="left"), len(t) - 1)]  # the value of the step holding each instant
    for value, (lo, hi) in zip(m.y, edges):
        inside = (fine > lo) & (fine <= hi)
        assert value == pytest.approx(held[inside].mean(), abs=2e-4)
    with pytest.raises(CompareError):
        interval_means(Series.of(t[:1], y[:1]), samples)
