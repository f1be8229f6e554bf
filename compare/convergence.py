"""Convergence studies: observed order and Richardson extrapolation.

``h`` is the resolution (dx, or a relative cell size); levels need not be ordered.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from compare.io import CompareError


@dataclass(frozen=True)
class OrderResult:
    order: float  # least-squares slope of log|e| against log h
    pairwise: tuple[float, ...]  # log(e_i / e_{i+1}) / log(h_i / h_{i+1}), coarse to fine
    constant: float  # C in e = C h^p from the fit


def _sorted_coarse_first(h: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    h = np.asarray(h, dtype=float)
    v = np.asarray(v, dtype=float)
    if h.shape != v.shape or h.ndim != 1:
        raise CompareError("convergence: h and values must be 1-D arrays of equal length")
    order = np.argsort(-h, kind="stable")
    return h[order], v[order]


def observed_order(h: np.ndarray, errors: np.ndarray) -> OrderResult:
    """Observed order p of errors ``e ~ C h^p`` (errors against a reference)."""
    h, e = _sorted_coarse_first(h, errors)
    e = np.abs(e)
    keep = (h > 0) & (e > 0) & np.isfinite(e)
    h, e = h[keep], e[keep]
    if len(h) < 2:
        raise CompareError("convergence: need at least two levels with non-zero errors")
    slope, intercept = np.polyfit(np.log(h), np.log(e), 1)
    pairwise = tuple(
        float(math.log(e[i] / e[i + 1]) / math.log(h[i] / h[i + 1])) for i in range(len(h) - 1)
    )
    return OrderResult(float(slope), pairwise, float(math.exp(intercept)))


@dataclass(frozen=True)
class RichardsonResult:
    order: float  # observed order from the three finest levels
    extrapolated: float  # estimate of the h -> 0 value
    h: tuple[float, ...]  # coarse to fine
    values: tuple[float, ...]
    errors: tuple[float, ...]  # value - extrapolated, per level


LEAST_ORDER = 1e-3  # a smaller observed order is no convergence: nothing to extrapolate


def richardson(h: np.ndarray, values: np.ndarray) -> RichardsonResult:
    """Richardson extrapolation from the three finest levels (f = f* + C h^p).

    With a constant refinement ratio r: p = ln((f1 - f2) / (f2 - f3)) / ln r and
    f* = f3 + (f3 - f2) / (r^p - 1) (f1 coarsest). Other ratios: p solved numerically.
    Raises CompareError when convergence is not monotone (the ratio of differences <= 0) or
    the differences do not shrink (no positive order).
    """
    h, f = _sorted_coarse_first(h, values)
    if len(h) < 3:
        raise CompareError("Richardson extrapolation needs at least three levels")
    h1, h2, h3 = h[-3:]
    f1, f2, f3 = f[-3:]
    d12, d23 = f1 - f2, f2 - f3
    if d23 == 0 or d12 == 0:
        if d12 == 0 and d23 == 0:
            return RichardsonResult(math.inf, float(f3), tuple(h), tuple(f),
                                    tuple(float(x - f3) for x in f))
        raise CompareError("Richardson extrapolation: two levels give identical values")
    ratio = d12 / d23
    if ratio <= 0:
        raise CompareError(
            f"Richardson extrapolation: oscillatory convergence (values {f1:g}, {f2:g}, {f3:g})"
        )
    r12, r23 = h1 / h2, h2 / h3
    if math.isclose(r12, r23, rel_tol=1e-9):
        p = math.log(ratio) / math.log(r23)
        if not p >= LEAST_ORDER:  # equal differences (a quantised measure) or growing ones
            raise CompareError(f"Richardson extrapolation: the differences do not shrink under "
                               f"refinement (values {f1:g}, {f2:g}, {f3:g})")
    else:
        def residual(p: float) -> float:
            return (h1**p - h2**p) / (h2**p - h3**p) - ratio

        try:
            p = brentq(residual, LEAST_ORDER, 20.0)
        except ValueError:
            raise CompareError(
                "Richardson extrapolation: no order in (0, 20] fits these values"
            ) from None
    c = d23 / (h2**p - h3**p)
    f_star = f3 - c * h3**p
    return RichardsonResult(float(p), float(f_star), tuple(map(float, h)), tuple(map(float, f)),
                            tuple(float(x - f_star) for x in f))
