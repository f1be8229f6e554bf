"""Field comparison: pressure along a vertical line and the free-surface profile.

Particles (IQ-MPM frames) and cells (interFoam foamToVTK) are reduced to 1-D profiles,
then interpolated onto common points and compared (relative L2, max difference).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from compare.io import CellField, CompareError, ParticleFrame


@dataclass(frozen=True)
class Profile:
    """Values ``v`` at coordinates ``s`` (y for a pressure line, x for a free surface)."""

    s: np.ndarray
    v: np.ndarray
    label: str
    time: float = math.nan


@dataclass(frozen=True)
class ProfileError:
    s: np.ndarray  # common points
    ours: np.ndarray
    ref: np.ndarray
    rel_l2: float  # ||ours - ref|| / ||ref|| over the common points
    max_abs: float  # max |ours - ref|


def particle_spacing(points: np.ndarray, dim: int = 2) -> float:
    """Median nearest-neighbour distance of particles (their typical spacing)."""
    pts = np.asarray(points)[:, :dim]
    if len(pts) < 2:
        raise CompareError("particle frame has fewer than two particles")
    dist, _ = cKDTree(pts).query(pts, k=2)
    return float(np.median(dist[:, 1]))


def _fluid(frame: ParticleFrame, fluid_material: int) -> np.ndarray:
    mask = frame.material == fluid_material
    if not np.any(mask):
        raise CompareError(
            f"{frame.path}: no particles with material {fluid_material} (the fluid id); "
            f"materials present: {sorted(set(frame.material.tolist()))}"
        )
    return mask


def particle_pressure_line(frame: ParticleFrame, x0: float, fluid_material: int = 0,
                           dim: int = 2, label: str = "IQ-MPM") -> Profile:
    """Mean fluid-particle pressure in y bins of 2 spacings, within 1.5 spacings of x0."""
    mask = _fluid(frame, fluid_material)
    pts = frame.points[mask]
    p = frame.pressure[mask]
    h = particle_spacing(pts, dim)
    near = np.abs(pts[:, 0] - x0) <= 1.5 * h
    if dim == 3:
        zc = 0.5 * (pts[:, 2].min() + pts[:, 2].max())
        near &= np.abs(pts[:, 2] - zc) <= 1.5 * h
    if np.count_nonzero(near) < 2:
        raise CompareError(f"{frame.path}: fewer than two fluid particles near x = {x0:g}")
    y, pv = pts[near, 1], p[near]
    edges = np.arange(y.min(), y.max() + 2 * h, 2 * h)
    idx = np.clip(np.digitize(y, edges) - 1, 0, len(edges) - 1)
    s, v = [], []
    for k in np.unique(idx):
        sel = idx == k
        s.append(float(np.mean(y[sel])))
        v.append(float(np.mean(pv[sel])))
    return Profile(np.array(s), np.array(v), label, frame.time)


def particle_free_surface(frame: ParticleFrame, fluid_material: int = 0, dim: int = 2,
                          label: str = "IQ-MPM") -> Profile:
    """Surface elevation per x bin (2 spacings wide): top particle + half a spacing."""
    mask = _fluid(frame, fluid_material)
    pts = frame.points[mask]
    h = particle_spacing(pts, dim)
    x, y = pts[:, 0], pts[:, 1]
    edges = np.arange(x.min(), x.max() + 2 * h, 2 * h)
    idx = np.clip(np.digitize(x, edges) - 1, 0, len(edges) - 1)
    s, v = [], []
    for k in np.unique(idx):
        sel = idx == k
        s.append(float(0.5 * (edges[k] + edges[k] + 2 * h)))
        v.append(float(np.max(y[sel]) + 0.5 * h))
    return Profile(np.array(s), np.array(v), label, frame.time)


def _columns(cells: CellField) -> tuple[np.ndarray, list[np.ndarray]]:
    """Cells grouped into vertical columns by their x extent (2-D meshes)."""
    key = np.round(cells.centres[:, 0] / max(np.min(cells.upper[:, 0] - cells.lower[:, 0]),
                                              1e-12) * 4.0).astype(np.int64)
    xs, groups = [], []
    for k in np.unique(key):
        sel = np.nonzero(key == k)[0]
        xs.append(float(np.mean(cells.centres[sel, 0])))
        groups.append(sel)
    return np.array(xs), groups


def cell_pressure_line(cells: CellField, x0: float, field: str = "p", alpha_min: float = 0.5,
                       label: str = "interFoam") -> Profile:
    """Cell pressure of the water cells (alpha.water >= alpha_min) whose x extent holds x0."""
    p = cells.field(field)
    alpha = cells.field("alpha.water")
    near = (cells.lower[:, 0] <= x0) & (cells.upper[:, 0] >= x0) & (alpha >= alpha_min)
    if cells.centres.shape[1] >= 3 and np.ptp(cells.centres[:, 2]) > 0:
        zc = 0.5 * (cells.lower[:, 2].min() + cells.upper[:, 2].max())
        near &= (cells.lower[:, 2] <= zc) & (cells.upper[:, 2] >= zc)
    if np.count_nonzero(near) < 2:
        raise CompareError(f"{cells.path}: fewer than two water cells at x = {x0:g}")
    y = cells.centres[near, 1]
    order = np.argsort(y)
    y, pv = y[order], p[near][order]
    uy, inv = np.unique(np.round(y, 12), return_inverse=True)
    v = np.bincount(inv, weights=pv) / np.bincount(inv)
    return Profile(uy, v, label, cells.time)


def cell_free_surface(cells: CellField, label: str = "interFoam") -> Profile:
    """Surface elevation per cell column: column bottom + sum(alpha.water * cell height)."""
    alpha = cells.field("alpha.water")
    xs, groups = _columns(cells)
    heights = cells.upper[:, 1] - cells.lower[:, 1]
    v = []
    for sel in groups:
        v.append(float(cells.lower[sel, 1].min() + np.sum(alpha[sel] * heights[sel])))
    return Profile(xs, np.array(v), label, cells.time)


def hydrostatic_profile(y: np.ndarray, depth: float, rho: float = 1000.0,
                        g: float = 9.81) -> Profile:
    """rho g (H - y) at the given heights."""
    y = np.asarray(y, dtype=float)
    return Profile(y, rho * g * (depth - y), "rho g (H - y)")


def hydrostatic_particle_error(frame: ParticleFrame, depth: float, fluid_material: int = 0,
                               rho: float = 1000.0, g: float = 9.81) -> float:
    """Relative L2 of particle pressure against rho g (H - y) over all fluid particles."""
    mask = _fluid(frame, fluid_material)
    exact = rho * g * (depth - frame.points[mask, 1])
    return float(np.linalg.norm(frame.pressure[mask] - exact) / np.linalg.norm(exact))


def compare_profiles(ours: Profile, ref: Profile, n: int = 101) -> ProfileError:
    """Both profiles linearly interpolated onto n uniform points of their common range."""
    if len(ours.s) < 2 or len(ref.s) < 2:
        raise CompareError(f"profiles '{ours.label}' / '{ref.label}' need two points each")
    lo = max(ours.s.min(), ref.s.min())
    hi = min(ours.s.max(), ref.s.max())
    if hi <= lo:
        raise CompareError(f"profiles '{ours.label}' and '{ref.label}' do not overlap")
    s = np.linspace(lo, hi, n)
    a = np.interp(s, *_sorted(ours))
    b = np.interp(s, *_sorted(ref))
    norm = float(np.linalg.norm(b))
    rel = float(np.linalg.norm(a - b) / norm) if norm > 0 else math.nan
    return ProfileError(s, a, b, rel, float(np.max(np.abs(a - b))))


def _sorted(p: Profile) -> tuple[np.ndarray, np.ndarray]:
    order = np.argsort(p.s)
    return p.s[order], p.v[order]
