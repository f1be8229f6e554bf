"""benchmarks/solvers/dual_cells.py against real dumps on grids that are not square (the 2-D
hydrostatic tank, 64 x 48 dual cells; the 3-D one cut to 32 x 20 x 24, since with nx = nz a
decoding that reads the axes in reverse order is a mere relabelling): the cell it decodes for each
unknown must agree with what the solver's matrix says about locality. The fluid-pressure block
of A = dt G^T M^-1 G couples only dual cells that share a corner (Q1-P0: the fluid velocity's
multilinear support spans two cells per axis), so every stored entry joins cells at most one
apart along each axis, face neighbours carry opposite checkerboard signs and corner neighbours
equal ones. A decoding with the axes' order swapped puts most coupled cells far apart on these
grids. Needs IQMPM_BIN (ctest sets it)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

REPO = Path(__file__).resolve().parent.parent.parent
BIN = os.environ.get("IQMPM_BIN")
sys.path.insert(0, str(REPO / "benchmarks" / "solvers"))
import dual_cells  # noqa: E402

pytestmark = pytest.mark.skipif(not BIN, reason="IQMPM_BIN is not set (ctest sets it)")


SCENES = {"hydrostatic_2d": [],
          "hydrostatic_3d": ["--set", "domain.max=[1.0,0.625,0.75]", "--set", "fluid.shapes.0.max=[1.0,0.5,0.75]"]}


@pytest.fixture(scope="module", params=list(SCENES))
def dump(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(request.param)
    scene = REPO / "benchmarks" / "hydrostatic" / f"{request.param}.json"
    result = subprocess.run([BIN, "run", str(scene), "-o", str(out), "--quiet", "--threads", "1",
                             "--set", "write_frames=false", "--set", "end_time=0.01", "--dump-system", "1",
                             *SCENES[request.param]], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-2000:]
    layout = json.loads((out / "layout_step1.json").read_text())
    A = sp.coo_matrix(scipy.io.mmread(str(out / "system_step1.mtx")))
    return layout, A


def pressure_rows(layout):
    block = next(b for b in layout["blocks"] if b["name"] == "p_f")
    return np.arange(block["offset"], block["offset"] + block["size"])


def test_no_two_axes_have_the_same_extent(dump):
    layout, _ = dump
    extent = dual_cells.box(layout)[1]
    assert len(set(extent)) == len(extent)


def test_coupled_cells_are_neighbours(dump):
    layout, A = dump
    rows = pressure_rows(layout)
    dual = np.asarray(layout["dual_cell"])
    assert np.all(dual[rows] >= 0)
    keep = np.isin(A.row, rows) & np.isin(A.col, rows) & (A.row != A.col)
    assert keep.sum() > 2 * len(rows), "too few couplings to test"
    gap = np.abs(dual_cells.coordinates(layout, dual[A.row[keep]]) - dual_cells.coordinates(layout, dual[A.col[keep]]))
    assert gap.max() == 1


def test_face_pairs_are_stored_entries_with_opposite_signs(dump):
    layout, A = dump
    rows = pressure_rows(layout)
    pairs = dual_cells.face_pairs(layout, rows)
    dim = len(layout["cells"])
    assert pairs.shape[1] > dim * len(rows) // 2, "an interior cell has 2 dim face neighbours"
    stored = set(zip(A.row.tolist(), A.col.tolist()))
    assert all((int(a), int(b)) in stored for a, b in pairs.T)
    dual = np.asarray(layout["dual_cell"])
    gap = np.abs(dual_cells.coordinates(layout, dual[pairs[0]]) - dual_cells.coordinates(layout, dual[pairs[1]]))
    assert np.all(gap.sum(axis=1) == 1)
    signs = dual_cells.parity_signs(layout)
    assert np.all(signs[pairs[0]] * signs[pairs[1]] == -1)
    # Corner neighbours (one apart along every axis) carry equal signs in 2-D, opposite in 3-D.
    keep = np.isin(A.row, rows) & np.isin(A.col, rows)
    corner = np.all(np.abs(dual_cells.coordinates(layout, dual[A.row[keep]])
                           - dual_cells.coordinates(layout, dual[A.col[keep]])) == 1, axis=1)
    assert corner.sum() > 0
    product = signs[A.row[keep][corner]] * signs[A.col[keep][corner]]
    assert np.all(product == (-1) ** dim)


def test_cell_index_inverts_the_layout(dump):
    layout, _ = dump
    lo, extent = dual_cells.box(layout)
    last = int(np.prod(extent)) - 1
    assert dual_cells.cell_index(layout, 0) == tuple(lo)
    assert dual_cells.cell_index(layout, last) == tuple(l + n - 1 for l, n in zip(lo, extent))
    assert dual_cells.cell_index(layout, 1) == tuple(lo[:-1]) + (lo[-1] + 1,)
