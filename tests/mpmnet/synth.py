"""Synthetic ``pressure_fields.h5`` files for the MPMNet tests (and for trying the CLIs).

``write_pressure_fields`` writes a file exactly as the contract in mpmnet/README.md says the
solver does (attributes, dtypes, one gzip chunk per step), so the tests read what the C++
writer is meant to produce. The field generators are cheap closed forms: a field constant
in time, a field linear in time, and a sloshing tank with a bobbing block (the three fields
with moving masks), which looks enough like a solver run to exercise training.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

import h5py
import numpy as np

FIELDS = ("fluid_pressure", "ghost_pressure", "interface")


def write_pressure_fields(path: Path, fields: np.ndarray, active: np.ndarray, *, dx: float,
                          scene_name: str, step: Optional[np.ndarray] = None,
                          dt: float = 1e-3, origin: Optional[Sequence[float]] = None,
                          field_names: Sequence[str] = FIELDS, format_version: int = 1,
                          fmt: str = "iqmpm-pressure-fields", fixed_strings: bool = False
                          ) -> Path:
    """Write ``path`` (a run folder gets ``pressure_fields.h5``); fields/active [S, C, *cells].

    Strings are variable-length UTF-8, as mpm/io/pressure_field_writer.cpp writes them, or
    fixed-length bytes with ``fixed_strings`` (what another HDF5 writer may produce).
    """
    text = np.bytes_ if fixed_strings else str
    path = Path(path)
    if path.suffix != ".h5":
        path.mkdir(parents=True, exist_ok=True)
        path = path / "pressure_fields.h5"
    S, C = fields.shape[:2]
    cells = fields.shape[2:]
    dim = len(cells)
    step = np.arange(1, S + 1, dtype=np.int64) if step is None else np.asarray(step, np.int64)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = text(fmt)
        f.attrs["format_version"] = np.int32(format_version)
        f.attrs["dim"] = np.int32(dim)
        f.attrs["dx"] = np.float64(dx)
        f.attrs["origin"] = np.zeros(dim) if origin is None else np.asarray(origin, np.float64)
        f.attrs["cells"] = np.asarray(cells, dtype=np.int32)
        f.attrs["scene_name"] = text(scene_name)
        f.attrs["fields"] = text(",".join(field_names))
        f.attrs["units"] = text("Pa")
        chunk = (1, C) + tuple(cells)
        f.create_dataset("fields", data=fields.astype(np.float32), chunks=chunk,
                         compression="gzip")
        f.create_dataset("active", data=active.astype(np.uint8), chunks=chunk,
                         compression="gzip")
        f.create_dataset("time", data=step * dt)
        f.create_dataset("dt", data=np.full(S, dt))
        f.create_dataset("step", data=step)
        f.create_dataset("iterations", data=np.full(S, 10, dtype=np.int32))
    return path


def _grid(cells, dx):
    axes = [(np.arange(n) + 0.5) * dx for n in cells]
    return np.meshgrid(*axes, indexing="ij")


def constant_fields(cells, steps: int, dx: float = 0.01, seed: int = 0):
    """A hydrostatic-like field that does not change: every step equals the first."""
    rng = np.random.default_rng(seed)
    X = _grid(cells, dx)
    base = 1000.0 * 9.81 * (cells[-1] * dx - X[-1]) + 50.0 * np.sin(7 * X[0] + rng.uniform())
    one = np.stack([base, 0.5 * base, 0.1 * base]).astype(np.float32)
    act = np.ones_like(one, dtype=np.uint8)
    act[1:, ..., : cells[-1] // 2] = 0  # ghost and interface only in part of the domain
    one *= act
    return np.repeat(one[None], steps, 0), np.repeat(act[None], steps, 0)


def linear_fields(cells, steps: int, dx: float = 0.01, rate: float = 0.02, seed: int = 0):
    """Fields that grow linearly in time (step n: base * (1 + rate n)), all cells active."""
    rng = np.random.default_rng(seed)
    X = _grid(cells, dx)
    base = np.stack([1.0 + X[0] + 2 * X[-1], 0.5 + np.cos(9 * X[0]), 0.2 + X[-1]])
    base = base * (1000.0 * rng.uniform(0.5, 2.0))
    n = np.arange(steps).reshape((steps, 1) + (1,) * len(cells))
    fields = (base[None] * (1.0 + rate * n)).astype(np.float32)
    return fields, np.ones(fields.shape, dtype=np.uint8)


def sloshing_fields(cells, steps: int, dx: float, dt: float = 2e-3, amplitude: float = 0.1,
                    seed: int = 0):
    """A sloshing tank with a bobbing block: p_f hydrostatic under a moving surface, p_g
    in the block, h on the cells around it; all three masks move with time."""
    rng = np.random.default_rng(seed)
    g, rho = 9.81, 1000.0
    X = _grid(cells, dx)
    x, y = X[0], X[-1]
    L, H = cells[0] * dx, cells[-1] * dx
    depth = 0.5 * H
    k1, k2 = np.pi / L, 2 * np.pi / L
    w1, w2 = (np.sqrt(g * k * np.tanh(k * depth)) for k in (k1, k2))
    a1, a2 = amplitude * depth, 0.3 * amplitude * depth * rng.uniform(0.5, 1.0)
    phase = rng.uniform(0, 2 * np.pi)
    bx = L * rng.uniform(0.35, 0.65)
    half = 0.08 * L
    out_f = np.zeros((steps, 3) + tuple(cells), np.float32)
    out_a = np.zeros((steps, 3) + tuple(cells), np.uint8)
    for n in range(steps):
        t = n * dt
        eta = depth + a1 * np.cos(k1 * x) * np.cos(w1 * t + phase) \
            + a2 * np.cos(k2 * x) * np.cos(w2 * t)
        by = depth + 0.3 * half * np.sin(1.7 * w1 * t)
        dist = np.maximum(np.abs(x - bx), np.abs(y - by))  # a square block
        if len(cells) == 3:
            dist = np.maximum(dist, np.abs(X[1] - 0.5 * cells[1] * dx))
        block = dist < half
        ring = (dist >= half) & (dist < half + 1.5 * dx)
        water = (y < eta) & ~block
        p = rho * g * (eta - y) + rho * a1 * w1 ** 2 * np.cos(k1 * x) * np.cos(w1 * t + phase) \
            * np.exp(-k1 * np.abs(y - depth)) / k1 * 0.2
        out_f[n, 0] = np.where(water, p, 0)
        out_a[n, 0] = water
        out_f[n, 1] = np.where(block, p + 200.0 * np.sin(3 * w1 * t) * (y - by) / half, 0)
        out_a[n, 1] = block
        hring = ring & (y < eta + dx)
        out_f[n, 2] = np.where(hring, np.maximum(p, 0), 0)
        out_a[n, 2] = hring
    return out_f, out_a
