"""Metrics that measure what they say (issue 23, item 7), on synthetic data with known answers:
the free surface of the connected water body, fitted periods with their uncertainty, and
absolute errors for quantities whose reference is zero."""

import math
from pathlib import Path

import numpy as np
import pytest

from compare import fields as fld
from compare.analysis import BenchmarkResult, ScalarRow, SeriesRow
from compare.errors import Series, series_error
from compare.io import CellField, Metrics, ParticleFrame, Run
from compare.reducers import fitted_period, scalar_value_u
from compare.registry import Benchmark, MetricSpec, ScalarSpec, lookup


# ----------------------------------------------------------------------------- free surface

def _frame(pts: np.ndarray) -> ParticleFrame:
    pts = np.column_stack([pts[:, 0], pts[:, 1], np.zeros(len(pts))])
    n = len(pts)
    return ParticleFrame(Path("synthetic"), 0.2, pts, np.zeros(n), np.zeros((n, 3)),
                         np.zeros(n, dtype=np.int32))


def _lattice(spacing: float, x0: float, x1: float, y0: float, y1: float) -> np.ndarray:
    xs = np.arange(x0 + spacing / 2, x1, spacing)
    ys = np.arange(y0 + spacing / 2, y1, spacing)
    X, Y = np.meshgrid(xs, ys)
    return np.column_stack([X.ravel(), Y.ravel()])


def _level(x):
    return 0.3 + 0.1 * x


def _water_with_spray(spacing: float) -> np.ndarray:
    body = _lattice(spacing, 0.0, 1.0, 0.0, 1.0)
    body = body[body[:, 1] < _level(body[:, 0])]
    droplet = _lattice(spacing, 0.50, 0.53, 0.80, 0.83)  # a 3 x 3 droplet 0.45 m up
    rng = np.random.default_rng(7)
    spray = np.column_stack([rng.uniform(0.2, 0.9, 40), rng.uniform(0.5, 0.95, 40)])  # loose
    return np.vstack([body, droplet, spray])


def test_free_surface_ignores_a_detached_droplet_and_spray():
    spacing = 0.01
    pts = _water_with_spray(spacing)
    frame = _frame(pts)
    surface = fld.particle_free_surface(frame, cell=2 * spacing)
    # the body's surface everywhere, the droplet's and the spray's columns included
    assert np.max(np.abs(surface.v - _level(surface.s))) < 2 * spacing
    under_droplet = (surface.s > 0.5) & (surface.s < 0.53)
    assert np.any(under_droplet)
    assert np.all(surface.v[under_droplet] < 0.40)
    # the same frame without the droplet and the spray gives the same profile
    clean = _frame(pts[pts[:, 1] < _level(pts[:, 0])])
    np.testing.assert_allclose(fld.particle_free_surface(clean, cell=2 * spacing).v, surface.v)
    # default grid (two particle spacings) gives the same
    assert np.max(np.abs(fld.particle_free_surface(frame).v
                         - _level(fld.particle_free_surface(frame).s))) < 2 * spacing


def test_free_surface_keeps_a_second_pool_and_an_overhanging_jet():
    """A second body of water (at least 5 % of the water) is water, not spray; a jet that
    overhangs the bulk is the surface where it is the top of the connected water."""
    spacing = 0.01
    left = _lattice(spacing, 0.0, 0.4, 0.0, 0.3)
    right = _lattice(spacing, 0.7, 1.0, 0.0, 0.1)  # 300 particles of 1500: a pool
    jet = _lattice(spacing, 0.4, 0.55, 0.25, 0.3)  # attached to the bulk's top right corner
    surface = fld.particle_free_surface(_frame(np.vstack([left, right, jet])), cell=2 * spacing)
    in_pool = surface.s > 0.7
    assert np.all(np.abs(surface.v[in_pool] - 0.1) < spacing)
    on_jet = (surface.s > 0.42) & (surface.s < 0.54)
    assert np.all(np.abs(surface.v[on_jet] - 0.3) < spacing)
    assert not np.any((surface.s > 0.56) & (surface.s < 0.69))  # dry floor: no points


def _cells(nx: int, ny: int, alpha: np.ndarray) -> CellField:
    xs, ys = np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1)
    lo = np.array([[xs[i], ys[j], 0.0] for j in range(ny) for i in range(nx)])
    up = np.array([[xs[i + 1], ys[j + 1], 0.01] for j in range(ny) for i in range(nx)])
    return CellField(Path("synthetic"), 0.2, 0.5 * (lo + up), lo, up, {"alpha.water": alpha})


def test_cell_free_surface_ignores_a_detached_droplet():
    nx = ny = 50
    cells = _cells(nx, ny, np.zeros(nx * ny))
    lo, up = cells.lower[:, 1], cells.upper[:, 1]
    level = _level(cells.centres[:, 0])
    alpha = np.clip((level - lo) / (up - lo), 0.0, 1.0)
    clean = fld.cell_free_surface(_cells(nx, ny, alpha.copy()))
    # one interface per column, full water below: the old rule's bottom + sum(alpha h)
    np.testing.assert_allclose(clean.v, _level(clean.s), atol=1e-12)
    droplet = ((cells.centres[:, 0] > 0.5) & (cells.centres[:, 0] < 0.56)
               & (cells.centres[:, 1] > 0.8) & (cells.centres[:, 1] < 0.86))
    alpha[droplet] = 1.0
    alpha[(cells.centres[:, 1] > 0.9) & (cells.centres[:, 0] < 0.1)] = 0.3  # mist: not water
    with_droplet = fld.cell_free_surface(_cells(nx, ny, alpha))
    np.testing.assert_allclose(with_droplet.v, clean.v, atol=1e-12)
    # particles and cells of the same water with spray agree
    mine = fld.particle_free_surface(_frame(_water_with_spray(0.01)), cell=0.02)
    e = fld.compare_profiles(mine, with_droplet)
    assert e.max_abs < 0.02 and e.rel_l2 < 0.02


# ----------------------------------------------------------------------------- periods

def _damped(t, period, rate=0.3, amplitude=0.02, noise=0.0, seed=0):
    y = 0.5 + amplitude * np.exp(-rate * t) * np.cos(2 * np.pi * t / period + 0.3)
    if noise:
        y = y + noise * amplitude * np.random.default_rng(seed).standard_normal(t.size)
    return y


def test_fitted_period_holds_the_truth_within_its_uncertainty():
    period = 0.85
    t = np.arange(0.0, 5.0, 0.002)
    exact = fitted_period(t, _damped(t, period), periods=2.0)
    assert exact.value == pytest.approx(period, rel=1e-6)
    assert exact.window[0] == 0.0 and exact.window[1] == pytest.approx(2 * period, abs=0.003)
    assert exact.decay_rate == pytest.approx(0.3, rel=1e-4)
    inside, widths = 0, []
    for seed in range(20):
        fit = fitted_period(t, _damped(t, period, noise=0.1, seed=seed), periods=2.0)
        inside += abs(fit.value - period) <= fit.uncertainty
        widths.append(fit.uncertainty)
    assert inside >= 17  # an expanded (k = 2, ~95 %) uncertainty: about 19 of 20
    assert 1e-4 < np.median(widths) < 0.02  # not a uselessly wide bound either


def test_fitted_period_uncertainty_shrinks_with_more_periods():
    period = 0.85
    t = np.arange(0.0, 12.0, 0.002)
    y = _damped(t, period, rate=0.05, noise=0.1, seed=1)
    fits = [fitted_period(t, y, periods=n) for n in (1.0, 2.0, 4.0, 8.0)]
    widths = [f.uncertainty for f in fits]
    assert all(b < a for a, b in zip(widths, widths[1:]))
    for f in fits:
        assert abs(f.value - period) <= f.uncertainty


def test_fitted_period_with_coloured_residuals_widens_the_uncertainty():
    """A second, unresolved oscillation in the residual: the uncertainty grows (lag-1
    autocorrelation of the residuals) and still holds the true period."""
    period = 0.85
    t = np.arange(0.0, 5.0, 0.002)
    y = _damped(t, period) + 0.002 * np.sin(2 * np.pi * t / 0.31)
    fit = fitted_period(t, y, periods=2.0)
    assert abs(fit.value - period) <= fit.uncertainty


def test_early_period_survives_a_wave_that_shifts_the_swing():
    """The failure of the old crossing count (-32.5 % on heave_period against interFoam L1,
    whose early_period read 1.253 s for a swing of about 0.85 s): waves returning from the
    tank walls pull the block below the late equilibrium for a while, the swing does not cross
    that mean, two half-cycles merge and 'two periods' span 2.5. The fit reads the period and
    says how sure it is, the same at 10 ms and 1 ms output."""
    from compare.reducers import early_period

    period = 0.85
    spec = next(s for s in lookup("floating_block").scalars if s.name == "heave_period")
    widths = []
    for dt in (0.01, 0.001):
        t = np.arange(0.0, 5.0, dt)
        y = (0.504 + 0.016 * np.exp(-0.4 * t) * np.cos(2 * np.pi * t / period)
             - 0.008 * np.exp(-((t - 1.7) / 0.35) ** 2))
        assert early_period(t, y, 0.4) > 1.4 * period  # the old estimate
        run = Run(Path("synthetic"), "interFoam", {"status": "ok"},
                  Metrics(Path("synthetic"), t, {"com_y": y}))
        value, u = scalar_value_u(run, spec)
        assert abs(value - period) <= u < 0.15 * period
        widths.append(u)
    assert widths[0] == pytest.approx(widths[1], rel=0.1)


def test_period_rows_flag_only_differences_beyond_the_combined_uncertainty():
    row = ScalarRow("heave_period", "", "IQ-MPM", 0.845, 0.856, "interFoam", "s", 0.014, 0.010)
    assert row.combined_uncertainty == pytest.approx(math.hypot(0.014, 0.010))
    assert row.beyond_uncertainty is False
    far = ScalarRow("heave_period", "", "IQ-MPM", 0.845, 1.253, "interFoam", "s", 0.014, 0.010)
    assert far.beyond_uncertainty is True
    assert ScalarRow("x", "", "r", 1.0, 2.0, "ref", "m").beyond_uncertainty is None


def test_frequency_reducer_has_an_uncertainty():
    t = np.arange(0.0, 2.0, 0.001)
    y = -3.386e-3 + 1e-3 * np.exp(-2.0 * t) * np.cos(2 * np.pi * 10.7 * t)
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"},
              Metrics(Path("synthetic"), t, {"tip_dy": y}))
    spec = next(s for s in lookup("cantilever").scalars if s.name == "first_frequency")
    value, u = scalar_value_u(run, spec)
    assert value == pytest.approx(10.7, rel=1e-6)
    assert u < 1e-3


def test_window_mean_is_the_time_average_over_its_window():
    # p = 1000 + 500 sin(2 pi 40 t) sampled unevenly (a solver's adaptive steps): over
    # 0.35-0.5 s the sine's six whole periods average to zero, leaving 1000 exactly up to
    # the trapezoid rule's error; a constant series reads its constant, a run that ends
    # before the window reads NaN.
    rng = np.random.default_rng(3)
    t = np.sort(np.concatenate([[0.0, 0.6], rng.uniform(0.0, 0.6, 6000)]))
    p = 1000 + 500 * np.sin(2 * np.pi * 40 * t)
    spec = next(s for s in lookup("dam_break").scalars if s.name == "pressure_right_3cm_mean_0.35-0.5s")
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"},
              Metrics(Path("synthetic"), t, {"pressure_right_3cm": p}))
    value, _ = scalar_value_u(run, spec)
    assert value == pytest.approx(1000, abs=1.0)
    # the window and nothing else: a step outside it does not count
    stepped = np.where(t < 0.3, 9e9, 250.0)
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"},
              Metrics(Path("synthetic"), t, {"pressure_right_3cm": stepped}))
    assert scalar_value_u(run, spec)[0] == pytest.approx(250.0, rel=1e-3)
    short = t < 0.3
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"},
              Metrics(Path("synthetic"), t[short], {"pressure_right_3cm": p[short]}))
    assert math.isnan(scalar_value_u(run, spec)[0])


# ----------------------------------------------------------------------------- zero references

def test_zero_reference_scalar_reports_an_absolute_error():
    row = ScalarRow("angle_end", "", "IQ-MPM", 0.035, 0.0, "0", "rad")
    assert math.isnan(row.rel_error) and row.abs_error == pytest.approx(0.035)
    # a reference within the stated noise floor is zero too: absolute, with the unit
    noisy = ScalarRow("angle_end", "", "IQ-MPM", 0.035, 0.0005, "interFoam", "rad", zero_floor=0.01)
    assert noisy.is_absolute and math.isnan(noisy.rel_error)
    assert noisy.abs_error == pytest.approx(0.0345)
    assert not ScalarRow("x", "", "r", 0.035, 0.02, "ref", "rad", zero_floor=0.01).is_absolute
    flagged = ScalarRow("x", "", "r", 0.035, 0.5, "ref", "rad", absolute=True)
    assert math.isnan(flagged.rel_error)


def test_zero_quantity_series_shown_as_absolute(tmp_path):
    """The heaving block's rotation: noise against noise is compared in radians (RMS
    difference), the relative L2 (96 % on the real runs) is not shown."""
    from compare.report import write_report

    spec = lookup("floating_block").metric("angle")
    assert spec is not None and spec.absolute
    assert not lookup("floating_block_roll").metric("angle").absolute
    t = np.linspace(0.0, 5.0, 501)
    ours = Series.of(t, 0.02 * np.sin(7 * t))
    ref = Series.of(t, 0.02 * np.cos(5 * t))
    err = series_error(ours, ref)
    bench = Benchmark("zero", "zero", 2, None,
                      metrics=(MetricSpec("angle", "rad", "rotation", absolute=True),),
                      scalars=(ScalarSpec("angle_end", "rad", "end", reference=0.0,
                                          reference_label="0", column="angle"),))
    result = BenchmarkResult(bench, [], [])
    result.series_rows.append(SeriesRow("angle", "IQ-MPM", "interFoam", "rad", "s", err, True))
    result.scalar_rows.append(ScalarRow("angle_end", "end", "IQ-MPM", 0.01, 0.0, "0", "rad"))
    text = write_report(result, tmp_path).read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("| `angle` (absolute)"))
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[5] == "n/a" and cells[6].endswith(" rad") and cells[9] == "n/a"
    scalar = next(ln for ln in text.splitlines() if ln.startswith("| `angle_end`"))
    assert "| n/a | 0.01 rad |" in scalar


def test_expected_criterion_on_a_zero_quantity_needs_an_absolute_margin():
    from compare.expected import parse_check
    from compare.io import CompareError

    bench = lookup("floating_block")
    raw = {"metric": "angle", "value": "interFoam", "margin": {"relative": 0.5}, "source": "s"}
    with pytest.raises(CompareError, match="absolute margin"):
        parse_check(Path("expected.json"), bench, 0, raw)
    raw["margin"] = {"absolute": 0.02}
    assert parse_check(Path("expected.json"), bench, 0, raw).margin.kind == "absolute"


def test_largest_change_is_the_farthest_excursion_with_its_sign():
    # A volume that dips by 3 % and recovers to -0.5 % reads -0.03, not the end's -0.005; a
    # rise of 1 % beside it does not hide the dip; a constant series reads 0. The same
    # spec on both dam breaks.
    t = np.linspace(0.0, 1.0, 1001)
    dip = 0.04 * (1 - 0.03 * np.exp(-((t - 0.3) / 0.05) ** 2) + 0.01 * np.exp(-((t - 0.8) / 0.05) ** 2)
                  - 0.005 * (t > 0.9))
    for benchmark in ("dam_break", "dam_break_obstacle"):
        spec = next(s for s in lookup(benchmark).scalars if s.name == "volume_largest_change")
        run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"volume": dip}))
        assert scalar_value_u(run, spec)[0] == pytest.approx(-0.03, rel=1e-3)
        flat = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"volume": np.full_like(t, 0.04)}))
        assert scalar_value_u(flat, spec)[0] == 0.0


def test_std_tail_is_the_noise_over_the_tail_only():
    # A force at rest, 196.2 N/m, with an alternating +-2 N/m in the last half and a large
    # swing before it: the scalar over the last 50 % reads the alternation's 2 N/m, not
    # the swing; a steady series reads 0.
    t = np.linspace(0.0, 1.0, 1001)
    f = np.where(t < 0.4, 196.2 + 150 * np.sin(40 * t), 196.2 + 2.0 * (-1.0) ** np.arange(len(t)))
    spec = next(s for s in lookup("submerged_block").scalars if s.name == "block_force_y_std")
    run = Run(Path("synthetic"), "iqmpm", {"status": "ok"}, Metrics(Path("synthetic"), t, {"block_force_y": f}))
    assert scalar_value_u(run, spec)[0] == pytest.approx(2.0, rel=1e-3)
    steady = Run(Path("synthetic"), "iqmpm", {"status": "ok"},
                 Metrics(Path("synthetic"), t, {"block_force_y": np.full_like(t, 196.2)}))
    assert scalar_value_u(steady, spec)[0] == pytest.approx(0.0, abs=1e-12)
