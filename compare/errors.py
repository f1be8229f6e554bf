"""Error measures of benchmarks.md, "What error means in the comparison reports".

* Time series against a reference series: relative L2 over the common time window, after
  interpolating the finer series (more samples in the window) onto the coarser one's
  times; peak value error; peak time error.
* Scalar: relative error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from compare.io import CompareError


@dataclass(frozen=True)
class Series:
    """A time series: times ``t`` and values ``y`` (NaNs dropped, sorted by time)."""

    t: np.ndarray
    y: np.ndarray
    label: str = ""

    @staticmethod
    def of(t: np.ndarray, y: np.ndarray, label: str = "") -> "Series":
        t = np.asarray(t, dtype=float)
        y = np.asarray(y, dtype=float)
        if t.shape != y.shape:
            raise CompareError(f"series '{label}': t and y differ in length")
        keep = np.isfinite(t) & np.isfinite(y)
        t, y = t[keep], y[keep]
        order = np.argsort(t, kind="stable")
        return Series(t[order], y[order], label)

    def scaled(self, t_scale: float = 1.0, y_scale: float = 1.0) -> "Series":
        return Series(self.t * t_scale, self.y * y_scale, self.label)


@dataclass(frozen=True)
class SeriesError:
    """Errors of ``ours`` against ``reference`` over the common window."""

    window: tuple[float, float]
    n_points: int  # samples of the coarser series in the window
    rel_l2: float  # sqrt(int (y - r)^2 dt / int r^2 dt); NaN when the reference is zero
    rms: float  # sqrt(int (y - r)^2 dt / window length), in the series' unit
    peak_ours: float
    peak_ref: float
    t_peak_ours: float
    t_peak_ref: float

    @property
    def peak_rel_error(self) -> float:
        """(peak_ours - peak_ref) / |peak_ref|, signed."""
        return relative_error(self.peak_ours, self.peak_ref)

    @property
    def peak_time_error(self) -> float:
        """t_peak_ours - t_peak_ref, in the series' time unit."""
        return self.t_peak_ours - self.t_peak_ref


def relative_error(value: float, reference: float) -> float:
    """(value - reference) / |reference|; NaN when the reference is zero."""
    if reference == 0 or not math.isfinite(reference):
        return math.nan
    return (value - reference) / abs(reference)


def common_window(a: Series, b: Series) -> tuple[float, float]:
    if len(a.t) == 0 or len(b.t) == 0:
        raise CompareError(f"empty series: '{a.label if len(a.t) == 0 else b.label}'")
    lo = max(a.t[0], b.t[0])
    hi = min(a.t[-1], b.t[-1])
    if hi < lo:
        raise CompareError(
            f"series '{a.label}' [{a.t[0]:g}, {a.t[-1]:g}] and '{b.label}' "
            f"[{b.t[0]:g}, {b.t[-1]:g}] do not overlap in time"
        )
    return float(lo), float(hi)


def _in_window(s: Series, lo: float, hi: float) -> Series:
    eps = 1e-12 * max(1.0, abs(hi))
    keep = (s.t >= lo - eps) & (s.t <= hi + eps)
    return Series(s.t[keep], s.y[keep], s.label)


def on_common_times(ours: Series, ref: Series) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Both series on the coarser one's times within the common window.

    Returns ``(t, y_ours, y_ref)``. The coarser series is the one with fewer samples in the
    window (ties: the reference); the other is linearly interpolated onto its times.
    """
    lo, hi = common_window(ours, ref)
    a = _in_window(ours, lo, hi)
    b = _in_window(ref, lo, hi)
    if len(a.t) < len(b.t):
        return a.t, a.y, np.interp(a.t, ref.t, ref.y)
    return b.t, np.interp(b.t, ours.t, ours.y), b.y


def _integral(t: np.ndarray, f: np.ndarray) -> float:
    """Trapezoid rule in time; a plain mean over samples when the window is one instant."""
    if len(t) >= 2 and t[-1] > t[0]:
        return float(np.trapz(f, t))
    return float(np.mean(f)) if len(f) else math.nan


def peak(s: Series) -> tuple[float, float]:
    """Value and time of the sample of largest magnitude (sign kept)."""
    i = int(np.argmax(np.abs(s.y)))
    return float(s.y[i]), float(s.t[i])


def series_error(ours: Series, ref: Series) -> SeriesError:
    """All errors of ``ours`` against ``ref`` (see module docstring)."""
    lo, hi = common_window(ours, ref)
    t, y, r = on_common_times(ours, ref)
    diff2 = _integral(t, (y - r) ** 2)
    ref2 = _integral(t, r**2)
    rel = math.sqrt(diff2 / ref2) if ref2 > 0 else math.nan
    length = (t[-1] - t[0]) if len(t) >= 2 and t[-1] > t[0] else 1.0
    rms = math.sqrt(max(diff2, 0.0) / length)
    a = _in_window(ours, lo, hi)
    b = _in_window(ref, lo, hi)
    peak_a, t_a = peak(a)
    peak_b, t_b = peak(b)
    return SeriesError((lo, hi), len(t), rel, rms, peak_a, peak_b, t_a, t_b)


def interval_means(ours: Series, at: np.ndarray) -> Series:
    """A per-step quantity (each value held over its step, (t_{k-1}, t_k]: a force as the
    step's impulse over dt) as its mean over the interval of each time of ``at`` (from
    halfway to the time before to halfway to the time after; the ends' half-intervals
    mirrored): the impulse a sampled reference stands for. Times of ``at`` whose interval
    leaves ``ours`` are dropped.

    Why: in an incompressible model the water stopped in one step against a body gives a
    force of its impulse over dt, so a single step's value grows as dt shrinks, while the
    impulse over a fixed interval does not (compare/README.md, "Per-step quantities").
    """
    at = np.asarray(at, dtype=float)
    if len(ours.t) < 2 or len(at) < 2:
        raise CompareError(f"series '{ours.label}': too few samples for interval means")
    mid = 0.5 * (at[1:] + at[:-1])
    lo = np.r_[at[0] - (mid[0] - at[0]), mid]
    hi = np.r_[mid, at[-1] + (at[-1] - mid[-1])]
    impulse = np.r_[0.0, np.cumsum(ours.y[1:] * np.diff(ours.t))]  # at ours.t, linear between
    keep = (lo >= ours.t[0]) & (hi <= ours.t[-1])
    means = (np.interp(hi[keep], ours.t, impulse) - np.interp(lo[keep], ours.t, impulse)) / (hi[keep] - lo[keep])
    return Series(at[keep], means, ours.label)


def constant_series(value: float, t: np.ndarray, label: str = "") -> Series:
    """A constant (analytic) reference sampled at ``t``."""
    t = np.asarray(t, dtype=float)
    return Series.of(t, np.full_like(t, value), label)
