"""Metric extraction from a finished case, one function per quantity.

Every function returns (times, values); `merge` puts them on common rows.
Forces are divided by the cell thickness dz (per unit depth, N/m), volumes
likewise (m^2 per unit depth).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .parse import read_fo_series, read_sets, read_sixdof_log

Series = tuple[np.ndarray, np.ndarray]


def front_x(case: Path, fo: str = "lines", set_name: str = "floor",
            x_wall: float = 0.0) -> Series:
    """Surge front: the farthest x where alpha.water on the bottom cell row
    crosses 0.5, interpolated linearly between cell centres."""
    times, snaps = read_sets(case, fo, f"{set_name}_alpha.water.xy")
    out = np.full(len(times), np.nan)
    for i, arr in enumerate(snaps):
        if arr.size == 0:
            continue
        x, a = arr[:, 0], arr[:, 1]
        wet = np.nonzero(a >= 0.5)[0]
        if wet.size == 0:
            out[i] = x_wall
            continue
        k = wet[-1]
        if k + 1 < len(x) and a[k] > a[k + 1]:
            out[i] = x[k] + (a[k] - 0.5) / (a[k] - a[k + 1]) * (x[k + 1] - x[k])
        else:
            out[i] = x[k]
    return times, out


def column_height(case: Path, fo: str, set_name: str) -> Series:
    """Water height along a vertical line: integral of alpha.water dy
    (uniform points, cell values; resolution 0.25 mm)."""
    times, snaps = read_sets(case, fo, f"{set_name}_alpha.water.xy")
    out = np.full(len(times), np.nan)
    for i, arr in enumerate(snaps):
        if arr.shape[0] > 1:
            out[i] = np.trapz(np.clip(arr[:, 1], 0.0, 1.0), arr[:, 0])
    return times, out


def probe(case: Path, fo: str, field: str, index: int = 0) -> Series:
    rows = read_fo_series(case, fo, field)
    return rows[:, 0], rows[:, 1 + index]


def volume(case: Path, dz: float, fo: str = "waterVolume") -> Series:
    rows = read_fo_series(case, fo, "volFieldValue.dat")
    return rows[:, 0], rows[:, 1] / dz


def max_speed(case: Path, fo: str = "speed") -> Series:
    # Columns after dropping words: t, min, loc(min) x3, max, loc(max) x3.
    rows = read_fo_series(case, fo, "fieldMinMax.dat")
    return rows[:, 0], rows[:, 5]


def force(case: Path, fo: str, component: int, dz: float) -> Series:
    """Total (pressure + viscous) force on the function object's patches,
    per unit depth. v1912 force.dat: Time, total(3), pressure(3), viscous(3)."""
    rows = read_fo_series(case, fo, "force.dat")
    return rows[:, 0], rows[:, 1 + component] / dz


def patch_average(case: Path, fo: str, component: int) -> Series:
    """surfaceFieldValue areaAverage of a vector: t, x, y, z."""
    rows = read_fo_series(case, fo, "surfaceFieldValue.dat")
    return rows[:, 0], rows[:, 1 + component]


def rigid_body(case: Path, log: Path) -> dict[str, Series]:
    """com_x, com_y and angle (rad, about +z, counter-clockwise) per step."""
    t, com, q = read_sixdof_log(log)
    angle = np.arctan2(q[:, 1, 0], q[:, 0, 0]) if len(t) else np.zeros(0)
    return {"com_x": (t, com[:, 0]), "com_y": (t, com[:, 1]), "angle": (t, angle)}


def merge(series: dict[str, Series], decimals: int = 9) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Rows at the times every series has (times rounded to `decimals`).

    Function objects write at the same adjusted instants; the rigid-body state
    (one entry per step) contains those instants too.
    """
    keyed = {}
    common: set[float] | None = None
    for name, (t, v) in series.items():
        d = {}
        for ti, vi in zip(np.round(t, decimals), v):
            d[float(ti)] = vi  # a later duplicate (restart) wins
        keyed[name] = d
        common = set(d) if common is None else common & set(d)
    times = np.array(sorted(common or []))
    cols = {name: np.array([keyed[name][ti] for ti in times]) for name in series}
    return times, cols
