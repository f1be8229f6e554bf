"""Where the unknowns of a dumped pressure system live: the dual cells of `layout_stepN.json`
(`iqmpm run ... --dump-system N`), shared by the studies in this folder.

A dump numbers each unknown's dual cell as GridLayout does (mpm/grid/grid.h): row-major over
the box [lo, lo + extent), first axis outermost, so in 2-D index = (i - lo_0) * extent_1 +
(j - lo_1). Dumps before 2026-12-05 have no `dual_cells` key; their box is [0, cells), which is
what the solver's dual-cell layout has always been. Needs numpy only (no PETSc).
"""
import numpy as np


def box(layout):
    """(lo, extent) of the dual cells' box."""
    if "dual_cells" in layout:
        return list(layout["dual_cells"]["lo"]), list(layout["dual_cells"]["extent"])
    return [0] * len(layout["cells"]), list(layout["cells"])


def strides(layout):
    """Index step of one cell along each axis (the last axis is contiguous)."""
    _, extent = box(layout)
    return [int(np.prod(extent[a + 1:])) for a in range(len(extent))]


def coordinates(layout, index):
    """Multi-indices (one row per entry of `index`, -1 everywhere for an index below 0)."""
    index = np.asarray(index, dtype=np.int64)
    lo, extent = box(layout)
    step = strides(layout)
    coords = np.stack([(np.maximum(index, 0) // step[a]) % extent[a] + lo[a] for a in range(len(extent))], axis=-1)
    return np.where((index >= 0)[..., None], coords, -1)


def cell_index(layout, k):
    """The multi-index of dual cell k, as a tuple."""
    return tuple(int(i) for i in coordinates(layout, [k])[0])


def parity_signs(layout):
    """(-1)^(i+j[+k]) of each unknown's dual cell, +1 for an unknown without one."""
    dual = np.asarray(layout["dual_cell"])
    parity = coordinates(layout, dual).sum(axis=1)
    return np.where((dual >= 0) & (parity % 2 == 1), -1.0, 1.0)


def face_pairs(layout, unknowns):
    """Pairs (2 x m array) of the given unknowns whose dual cells share a face (one unknown per
    cell among them, e.g. one block's)."""
    dual = np.asarray(layout["dual_cell"])
    unknowns = np.asarray(unknowns, dtype=np.int64)
    unknowns = unknowns[dual[unknowns] >= 0]
    _, extent = box(layout)
    where = -np.ones(int(np.prod(extent)), dtype=np.int64)
    where[dual[unknowns]] = unknowns
    coords = coordinates(layout, dual[unknowns])
    pairs = []
    for axis, stride in enumerate(strides(layout)):
        inside = coords[:, axis] - box(layout)[0][axis] < extent[axis] - 1
        neighbour = where[dual[unknowns[inside]] + stride]
        ok = neighbour >= 0
        pairs.append(np.stack([unknowns[inside][ok], neighbour[ok]]))
    return np.concatenate(pairs, axis=1)
