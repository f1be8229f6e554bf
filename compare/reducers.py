"""Scalars reduced from a run's time series: the reducers of the registry's scalar specs
(last value, means over a tail or a window, peaks, integrals, largest change) and the
periods, frequencies and decay ratios of an oscillation (zero crossings, spectral
estimate, damped-sine fits with their uncertainty).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from compare.errors import Series
from compare.io import CompareError, Run
from compare.registry import ScalarSpec


def reduce_series_u(t: np.ndarray, y: np.ndarray, reducer: str, tail: float = 0.5,
                    window: float = 0.0, until: float | None = None,
                    start: float | None = None) -> tuple[float, float]:
    """``reduce_series`` and the value's expanded uncertainty (k = 2; NaN for reducers
    without one: only the fitted periods, frequencies and decay ratios have one)."""
    if reducer == "decay":
        # The fitted envelope over the first two periods: every sample counts, not one
        # extremum a half-cycle (which sloshing and noise move).
        fit = fitted_period(t, y, periods=2.0)
        if not fit.periods >= 1.9:
            return math.nan, math.nan
        return fit.decay_ratio, fit.decay_ratio_uncertainty
    if reducer in ("early_period", "period", "frequency"):
        fit = fitted_period(t, y, periods=2.0 if reducer == "early_period" else None)
        if reducer == "frequency":
            if not fit.value > 0:
                return math.nan, math.nan
            return 1.0 / fit.value, fit.uncertainty / fit.value**2
        return fit.value, fit.uncertainty
    return reduce_series(t, y, reducer, tail, window, until, start), math.nan


def reduce_series(t: np.ndarray, y: np.ndarray, reducer: str, tail: float = 0.5,
                  window: float = 0.0, until: float | None = None,
                  start: float | None = None) -> float:
    if reducer in ("early_period", "period", "frequency", "decay"):
        return reduce_series_u(t, y, reducer, tail, window, until)[0]
    s = Series.of(t, y)
    if len(s.t) == 0:
        return math.nan
    if reducer == "window_peak":
        return window_peak(s.t, s.y, window)
    if reducer in ("integral", "window_mean"):
        begin = s.t[0] if start is None else max(start, s.t[0])
        end = s.t[-1] if until is None else min(until, s.t[-1])
        if reducer == "window_mean" and not end > begin:
            return math.nan  # the run does not reach the window
        fine = np.linspace(begin, end, max(2, int(round((end - begin) / 1e-4)) + 1))
        integral = float(np.trapz(np.interp(fine, s.t, s.y), fine))
        return integral if reducer == "integral" else integral / (end - begin)
    if reducer == "largest_change":
        # y / y(first sample) - 1 farthest from zero over the run, with its sign: a drift
        # that recovers by the end still counts.
        change = s.y / s.y[0] - 1.0
        return float(change[np.argmax(np.abs(change))])
    if reducer == "first":
        later = np.nonzero(s.t > 0)[0]
        return float(s.y[later[0]] if len(later) else s.y[0])
    if reducer == "last":
        return float(s.y[-1])
    if reducer == "max":
        return float(np.max(s.y))
    if reducer == "std_tail":
        # step-to-step noise of a quantity that should hold still (a force at rest)
        start = s.t[-1] - tail * (s.t[-1] - s.t[0])
        return float(np.std(s.y[s.t >= start]))
    if reducer == "mean_tail":
        start = s.t[-1] - tail * (s.t[-1] - s.t[0])
        return float(np.mean(s.y[s.t >= start]))
    if reducer == "mean_periods":
        # mean over whole periods of an oscillation about its equilibrium (the static value of
        # a decaying vibration): between the first and last upward mean crossing of the tail;
        # a series without two crossings (a steady solver) gives its last value.
        start = s.t[-1] - tail * (s.t[-1] - s.t[0])
        t_tail, y_tail = s.t[s.t >= start], s.y[s.t >= start]
        z = y_tail - np.mean(y_tail)
        up = np.nonzero((z[:-1] < 0) & (z[1:] >= 0))[0]
        if len(up) < 2:
            return float(s.y[-1])
        window = slice(up[0] + 1, up[-1] + 1)
        return float(np.trapz(y_tail[window], t_tail[window]) / (t_tail[up[-1]] - t_tail[up[0] + 1]))
    raise CompareError(f"unknown scalar reducer '{reducer}'")


def window_peak(t: np.ndarray, y: np.ndarray, window: float) -> float:
    """Largest mean of y over a sliding window of `window` seconds. The series is first
    interpolated to window / 100: a mean over the samples inside each window alone
    undercounts a coarse series (interFoam writes forces every 2 ms; a 10 ms window then
    holds 5 or 6 of them, and the sum of their trapezoids spans only 8 or 10 ms)."""
    if not window > 0:
        raise CompareError("reducer 'window_peak' needs a window > 0 s")
    if t[-1] - t[0] < window:
        return math.nan
    step = window / 100
    fine = np.arange(t[0], t[-1] + 0.5 * step, step)
    values = np.interp(fine, t, y)
    # Trapezoidal mean over each window of 101 points.
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (values[1:] + values[:-1]) * step)])
    means = (cumulative[100:] - cumulative[:-100]) / window
    return float(np.max(means))


def half_cycles(t: np.ndarray, y: np.ndarray, tail: float = 0.4) -> tuple[np.ndarray, np.ndarray]:
    """Half-cycles of a decaying oscillation: the largest |y - equilibrium| of each, in
    order, and the times at which each after the first began (the zero crossing).

    The equilibrium is the mean over the last ``tail`` fraction of the run. A half-cycle ends
    when the deviation crosses zero and then reaches beyond 5 % of the largest deviation on
    the other side, so jitter about the equilibrium does not split one half-cycle in two.
    """
    start = t[-1] - tail * (t[-1] - t[0])
    z = y - np.mean(y[t >= start])
    hysteresis = 0.05 * float(np.max(np.abs(z)))
    amplitudes: list[float] = []
    starts: list[float] = []
    sign = 1.0 if z[0] >= 0 else -1.0
    current = 0.0
    crossing = float(t[0])
    for i, value in enumerate(z):
        if i > 0 and sign * value <= 0 < sign * z[i - 1]:  # the latest crossing, interpolated
            crossing = float(t[i - 1] - z[i - 1] * (t[i] - t[i - 1]) / (value - z[i - 1]))
        if sign * value < -hysteresis:  # well over on the other side: a new half-cycle
            amplitudes.append(current)
            starts.append(crossing)
            sign, current = -sign, 0.0
        current = max(current, sign * value)
    amplitudes.append(current)
    return np.asarray(amplitudes), np.asarray(starts)


def half_cycle_amplitudes(t: np.ndarray, y: np.ndarray, tail: float = 0.4) -> np.ndarray:
    """Largest |y - equilibrium| of each half-cycle (see ``half_cycles``)."""
    return half_cycles(t, y, tail)[0]


def early_period(t: np.ndarray, y: np.ndarray, tail: float = 0.4, periods: int = 2) -> float:
    """Mean period over the first ``periods`` periods after the release, from the half-cycles'
    zero crossings (NaN with fewer); late sloshing and noise do not enter."""
    starts = half_cycles(t, y, tail)[1]
    if len(starts) < 2 * periods + 1:
        return math.nan
    return float((starts[2 * periods] - starts[0]) / periods)


@dataclass(frozen=True)
class PeriodFit:
    """A period fitted to a (damped) oscillation: ``value`` ± ``uncertainty`` (expanded, k = 2:
    twice the standard error), over ``window`` (s); ``periods`` whole periods it spans."""

    value: float
    uncertainty: float
    window: tuple[float, float]
    periods: float
    decay_rate: float  # 1/s of the fitted envelope exp(-rate (t - t0))
    # exp(-rate period): the envelope's ratio over one period, and its expanded uncertainty
    # (k = 2, from the covariance of rate and omega as the period's).
    decay_ratio: float = math.nan
    decay_ratio_uncertainty: float = math.nan


NO_PERIOD = PeriodFit(math.nan, math.nan, (math.nan, math.nan), 0.0, math.nan)


def _uniform(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    step = float(np.median(np.diff(t)))
    tu = np.arange(t[0], t[-1] + 0.5 * step, step)
    return tu, np.interp(tu, t, y)


def spectral_period(t: np.ndarray, y: np.ndarray) -> float:
    """Period of the largest peak of the amplitude spectrum (series resampled uniformly,
    mean removed, Hann window, zero-padded 16x, the peak refined by a parabola through the
    log magnitudes of its three bins); NaN without a peak above the lowest bin."""
    if len(t) < 8 or not t[-1] > t[0]:
        return math.nan
    tu, yu = _uniform(t, y)
    z = (yu - np.mean(yu)) * np.hanning(len(yu))
    n = 16 * len(z)
    mag = np.abs(np.fft.rfft(z, n))
    step = tu[1] - tu[0]
    freq = np.fft.rfftfreq(n, step)
    lowest = 1.5 / (tu[-1] - tu[0])  # at least 1.5 cycles in the record
    ok = np.nonzero(freq >= lowest)[0]
    if len(ok) < 3:
        return math.nan
    k = int(ok[np.argmax(mag[ok])])
    if k <= ok[0] or k >= len(mag) - 1:
        return math.nan
    la, lb, lc = np.log(mag[k - 1:k + 2] + 1e-300)
    shift = 0.5 * (la - lc) / (la - 2 * lb + lc) if (la - 2 * lb + lc) != 0 else 0.0
    f = freq[k] + shift * (freq[1] - freq[0])
    return float(1.0 / f) if f > 0 else math.nan


def _damped(tau: np.ndarray, c: float, a: float, b: float, rate: float,
            omega: float) -> np.ndarray:
    return c + np.exp(-rate * tau) * (a * np.cos(omega * tau) + b * np.sin(omega * tau))


def _fit_window(t: np.ndarray, y: np.ndarray, t0: float, period: float,
                periods: float | None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    from scipy.optimize import curve_fit

    end = t[-1] if periods is None else min(t[-1], t0 + periods * period)
    sel = (t >= t0) & (t <= end + 1e-12)
    tau, ys = t[sel] - t0, y[sel]
    if len(tau) < 8 or tau[-1] < 0.75 * period:
        return None
    omega = 2 * math.pi / period
    # c, a, b by linear least squares at the guessed frequency, no decay
    basis = np.column_stack([np.ones_like(tau), np.cos(omega * tau), np.sin(omega * tau)])
    (c, a, b), *_ = np.linalg.lstsq(basis, ys, rcond=None)
    try:
        p, cov = curve_fit(_damped, tau, ys, p0=[c, a, b, 0.1 / period, omega], maxfev=20000)
    except (RuntimeError, ValueError):
        return None
    if not np.all(np.isfinite(cov)) or p[4] <= 0:
        return None
    return p, cov, tau, ys


def correlation_time(r: np.ndarray) -> float:
    """Integrated autocorrelation time of ``r`` in samples: 1 + 2 sum_k rho_k over the lags
    k >= 1 up to the first non-positive autocorrelation rho_k (1 for white noise; at most
    len(r) / 2, so that at least two independent samples remain)."""
    r = np.asarray(r, dtype=float) - np.mean(r)
    n = len(r)
    if n < 3 or not np.any(r):
        return 1.0
    spec = np.fft.rfft(r, 2 * n)
    acf = np.fft.irfft(spec * np.conj(spec))[:n]
    rho = acf / acf[0]
    stop = np.nonzero(rho[1:] <= 0)[0]
    k = int(stop[0]) + 1 if len(stop) else n
    tau = 1.0 + 2.0 * float(np.sum(rho[1:k]))
    return float(min(max(tau, 1.0), n / 2.0))


def fitted_period(t: np.ndarray, y: np.ndarray, periods: float | None = 2.0,
                  t_start: float | None = None) -> PeriodFit:
    """Period of a (damped) oscillation by a least-squares fit of
    ``c + exp(-rate tau) (a cos(omega tau) + b sin(omega tau))``, tau = t - t0, over the window
    from t0 (``t_start``, else the first sample: the release) to t0 + ``periods`` fitted
    periods (None: to the end of the run). The fit is repeated with the window set by its own
    period until the period changes by less than 1e-6 (at most 8 times); first guesses: the
    spectral peak of the whole run and of its first half, and the half-cycles' zero crossings
    (``early_period``); the fit with the smallest RMS residual relative to the signal's RMS in
    its window wins.

    Uncertainty: twice the standard error of omega from the fit's covariance (scaled by the
    residual variance), times sqrt(tau), tau the residuals' integrated autocorrelation time in
    samples (``correlation_time``): residuals that are not white (waves returning from the
    walls, a second mode, output smoothing) carry fewer independent samples, and the standard
    error grows accordingly, the same whatever the output interval. NaN when the window holds
    less than 3/4 of a period or no fit converges.
    """
    s = Series.of(t, y)
    t, y = s.t, s.y
    if len(t) < 8 or not t[-1] > t[0]:
        return NO_PERIOD
    t0 = float(t[0] if t_start is None else t_start)
    half = t <= t[0] + 0.5 * (t[-1] - t[0])
    guesses = [spectral_period(t, y), spectral_period(t[half], y[half])]
    early = early_period(t, y)
    guesses.append(early)
    best: tuple[float, PeriodFit] | None = None
    for guess in guesses:
        if not (math.isfinite(guess) and guess > 0):
            continue
        period, fit = guess, None
        for _ in range(8):
            fit = _fit_window(t, y, t0, period, periods)
            if fit is None:
                break
            new = 2 * math.pi / fit[0][4]
            converged = periods is None or abs(new - period) <= 1e-6 * period
            period = new
            if converged:  # the whole run: the window does not depend on the period
                break
        if fit is None or not (math.isfinite(period) and period > 0):
            continue
        p, cov, tau, ys = fit
        resid = ys - _damped(tau, *p)
        signal = float(np.sqrt(np.mean((ys - p[0]) ** 2)))
        if signal <= 0:
            continue
        rel = float(np.sqrt(np.mean(resid**2))) / signal
        inflation = correlation_time(resid)
        sigma_omega = math.sqrt(max(cov[4, 4], 0.0) * inflation)
        u = 2.0 * period * period / (2 * math.pi) * sigma_omega
        # q = exp(-rate T), T = 2 pi / omega: dq/drate = -T q, dq/domega = rate T q / omega.
        q = math.exp(min(-p[3] * period, 700.0))  # a spurious fit must not overflow
        gradient = np.array([-period * q, p[3] * period * q / p[4]])
        q_variance = float(gradient @ cov[3:5, 3:5] @ gradient) * inflation
        est = PeriodFit(float(period), float(u), (t0, float(t0 + tau[-1])),
                        float(tau[-1] / period), float(p[3]), q, 2.0 * math.sqrt(max(q_variance, 0.0)))
        if best is None or rel < best[0]:
            best = (rel, est)
    return best[1] if best is not None else NO_PERIOD


def mean_period(t: np.ndarray, y: np.ndarray) -> float:
    """Mean time between upward crossings of the series' mean (NaN with < 2 crossings)."""
    z = y - np.mean(y)
    up = np.nonzero((z[:-1] < 0) & (z[1:] >= 0))[0]
    if len(up) < 2:
        return math.nan
    tc = t[up] - z[up] * (t[up + 1] - t[up]) / (z[up + 1] - z[up])
    return float(np.mean(np.diff(tc)))


def scalar_value(run: Run, spec: ScalarSpec) -> float | None:
    """The scalar of a run, or None when the run does not provide it."""
    found = scalar_value_u(run, spec)
    return None if found is None else found[0]


def scalar_value_u(run: Run, spec: ScalarSpec) -> tuple[float, float] | None:
    """The scalar of a run and its expanded uncertainty (NaN when the reducer gives none),
    or None when the run does not provide it."""
    if spec.summary_key:
        value = run.summary.get(spec.summary_key)
        if isinstance(value, (int, float)):
            return float(value), math.nan
        if run.metrics is not None and spec.summary_key in run.metrics.columns:
            return reduce_series(run.metrics.t, run.metrics.columns[spec.summary_key],
                                 "last"), math.nan
        return None
    if run.metrics is None or spec.column not in run.metrics.columns:
        return None
    y = run.metrics.columns[spec.column]
    if spec.subtract_column:
        if spec.subtract_column not in run.metrics.columns:
            return None
        y = y - run.metrics.columns[spec.subtract_column] + spec.offset
    if spec.use_abs:
        y = np.abs(y)
    return reduce_series_u(run.metrics.t, y, spec.reducer, spec.tail, spec.window, spec.until,
                           spec.start)
