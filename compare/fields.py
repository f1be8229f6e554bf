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


# ----------------------------------------------------------------- free surface
#
# The free surface is the top of the *connected water body*, the same rule on both sides:
#   1. an occupancy grid: a cell is water when it is at least half full (interFoam:
#      alpha.water >= 0.5; particles: a square grid of side `cell` (the run's dx, else two
#      particle spacings), a cell is water when it holds at least half as many fluid particles
#      as the bulk's cells do: the median count of the cells whose 8 neighbours are all occupied);
#   2. its connected components (8-connectivity: cells that share an edge or a corner);
#   3. the water body = the largest component and every component with at least
#      ``MIN_BODY_FRACTION`` of all water cells (a second pool); smaller components (detached
#      droplets, spray, thin sheets that hold less than half a cell) are dropped;
#   4. per column, the surface above the highest cell of the water body: particles: the highest
#      particle in that cell or the (partly filled) cell just above it + half a particle
#      spacing; interFoam: that cell's bottom + its alpha x height + alpha x height of the
#      cell just above it when that one is not water (the interface's two cells). A column
#      without a water-body cell has no point.
# In a column with one interface and full water below it the interFoam rule equals
# column bottom + sum(alpha x cell height), the rule used before (which also counted
# droplets by their volume and stacked a jet's water onto the column bottom).

MIN_BODY_FRACTION = 0.05


def _body_mask(labels: np.ndarray, n_labels: int) -> np.ndarray:
    """Labels of the water body's components (see step 3 above) as a boolean per label."""
    sizes = np.bincount(labels[labels > 0].ravel(), minlength=n_labels + 1)
    sizes[0] = 0
    keep = np.zeros(n_labels + 1, dtype=bool)
    if n_labels == 0:
        return keep
    total = sizes.sum()
    keep[int(np.argmax(sizes))] = True
    keep |= sizes >= MIN_BODY_FRACTION * total
    keep[0] = False
    return keep


def particle_free_surface(frame: ParticleFrame, fluid_material: int = 0, dim: int = 2,
                          label: str = "IQ-MPM", cell: float | None = None) -> Profile:
    """Top of the connected water body per grid column (rule above); 3-D frames are projected
    onto the x-y plane. ``cell``: the grid's cell size (the run's dx), else two particle
    spacings."""
    from scipy import ndimage

    mask = _fluid(frame, fluid_material)
    pts = frame.points[mask]
    h = particle_spacing(pts, dim)
    c = float(cell) if cell is not None and cell > 0 else 2.0 * h
    x, y = pts[:, 0], pts[:, 1]
    x0, y0 = float(x.min()), float(y.min())
    ix = np.floor((x - x0) / c).astype(np.int64)
    iy = np.floor((y - y0) / c).astype(np.int64)
    count = np.zeros((ix.max() + 1, iy.max() + 1), dtype=np.int64)
    np.add.at(count, (ix, iy), 1)
    occupied = count > 0
    padded = np.pad(occupied, 1)
    interior = occupied.copy()
    for dx_ in (-1, 0, 1):
        for dy_ in (-1, 0, 1):
            interior &= padded[1 + dx_:padded.shape[0] - 1 + dx_, 1 + dy_:padded.shape[1] - 1 + dy_]
    full = float(np.median(count[interior])) if np.any(interior) else float(count.max())
    water = count >= max(1.0, 0.5 * full)
    labels, n = ndimage.label(water, structure=np.ones((3, 3), dtype=int))
    body = _body_mask(labels, n)[labels]
    s, v = [], []
    for i in range(body.shape[0]):
        rows = np.nonzero(body[i])[0]
        if len(rows) == 0:
            continue
        top = rows[-1]
        sel = (ix == i) & ((iy == top) | (iy == top + 1))
        s.append(x0 + (i + 0.5) * c)
        v.append(float(np.max(y[sel]) + 0.5 * h))
    if not s:
        raise CompareError(f"{frame.path}: no water body (no cell at least half full)")
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


def _touching_pairs(cells: CellField) -> np.ndarray:
    """Pairs (i, j) of cells whose x-y boxes share an edge or a corner."""
    lo, up = cells.lower[:, :2], cells.upper[:, :2]
    size = up - lo
    tol = 1e-6 * float(np.min(size))
    reach = float(np.max(np.hypot(size[:, 0], size[:, 1])))
    pairs = cKDTree(cells.centres[:, :2]).query_pairs(reach * 1.001, output_type="ndarray")
    if len(pairs) == 0:
        return pairs.reshape(0, 2)
    a, b = pairs[:, 0], pairs[:, 1]
    gap = np.maximum(lo[a] - up[b], lo[b] - up[a])  # < 0 overlap, 0 touch, > 0 apart
    touch = np.all(gap <= tol, axis=1)
    return pairs[touch]


def cell_free_surface(cells: CellField, label: str = "interFoam") -> Profile:
    """Top of the connected water body per cell column (rule above)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    alpha = cells.field("alpha.water")
    xs, groups = _columns(cells)
    heights = cells.upper[:, 1] - cells.lower[:, 1]
    water = alpha >= 0.5
    idx = np.nonzero(water)[0]
    pairs = _touching_pairs(cells)
    pairs = pairs[water[pairs[:, 0]] & water[pairs[:, 1]]]
    local = -np.ones(len(alpha), dtype=np.int64)
    local[idx] = np.arange(len(idx))
    graph = coo_matrix((np.ones(len(pairs)), (local[pairs[:, 0]], local[pairs[:, 1]])),
                       shape=(len(idx), len(idx)))
    n, comp = connected_components(graph, directed=False)
    labels = np.zeros(len(alpha), dtype=np.int64)
    labels[idx] = comp + 1
    body = _body_mask(labels, n)[labels]
    s, v = [], []
    for x, sel in zip(xs, groups):
        sel = sel[np.argsort(cells.centres[sel, 1])]
        in_body = np.nonzero(body[sel])[0]
        if len(in_body) == 0:
            continue
        k = in_body[-1]
        top = sel[k]
        value = cells.lower[top, 1] + alpha[top] * heights[top]
        if k + 1 < len(sel) and not water[sel[k + 1]]:
            value += alpha[sel[k + 1]] * heights[sel[k + 1]]
        s.append(x)
        v.append(float(value))
    if not s:
        raise CompareError(f"{cells.path}: no water body (no cell with alpha.water >= 0.5)")
    return Profile(np.array(s), np.array(v), label, cells.time)


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
