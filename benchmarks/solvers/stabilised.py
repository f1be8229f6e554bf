#!/usr/bin/python3
"""A stabilised Q1-P0 on dumped IQ-MPM pressure systems (issue 21 item 2): what a pressure-jump
term does to multigrid's iterations and to the solution.

What it measures
    For each dump folder (`iqmpm run ... --dump-system N`: system_stepN.mtx, rhs_stepN.mtx,
    layout_stepN.json) and each strength eps it adds C = eps s L to the p_f block, L the graph
    Laplacian of face-neighbour fluid cells (6 on the diagonal in 3-D, -1 a face), s the median
    p_f diagonal over 24 (the interior stencil's diagonal in 3-D). C vanishes on a pressure linear
    in space and lifts a Q1-P0 checkerboard to 12 eps s. It reports
      - the change of the solution against A's own, ||x - x0||_A / ||x0||_A (A = D M^-1 D^T: the
        kinetic-energy norm of the velocity update), and ||C x|| / ||b||;
      - CG iterations to 1e-8 from zero with matrices.py's preconditioners on A + C;
      - with --as-preconditioner, CG on A itself with BoomerAMG (plain and on S A S) built on A + C.
    Figures: benchmarks/solvers/README.md.

How to run
    /usr/bin/python3 benchmarks/solvers/stabilised.py DUMP_DIR [DUMP_DIR ...] \
        [--eps 0,0.01,0.1] [--pcs boomeramg,boomeramg_flip,gamg_cb] [--as-preconditioner]
    The dumps as benchmarks/solvers/study.sh makes them (fine3d_dx*_corners). One thread.
"""
import argparse
import json
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.io  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402

import dual_cells  # noqa: E402  (benchmarks/solvers/dual_cells.py)
import matrices  # noqa: E402  (benchmarks/solvers/matrices.py: reader, PETSc set-up)
from matrices import PETSc  # noqa: E402


def face_laplacian(layout):
    """Graph Laplacian over face-neighbour dual cells of the p_f unknowns, and those unknowns."""
    n = layout["unknowns"]
    block = next(b for b in layout["blocks"] if b["name"] == "p_f")
    pf = np.arange(block["offset"], block["offset"] + block["size"])
    pf = pf[np.asarray(layout["dual_cell"])[pf] >= 0]
    rows, cols = dual_cells.face_pairs(layout, pf)
    W = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    W = (W + W.T).tocsr()
    return (sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W).tocsr(), pf


def read_dump(folder):
    _, system, rhs, layout_path = matrices.find_systems(folder)[0]
    A, _ = matrices.read_system(system)
    b = scipy.io.mmread(str(rhs))
    b = np.asarray(b.todense() if sp.issparse(b) else b).ravel()
    return A, b, json.load(open(layout_path))


def cg_on_a_amg_on(A, P, b, signs=None):
    """CG iterations on A with BoomerAMG built on P (both flipped by `signs` if given)."""
    if signs is not None:
        S = sp.diags(signs)
        A, P, b = (S @ A @ S).tocsr(), (S @ P @ S).tocsr(), S @ b
    ksp = PETSc.KSP().create()
    ksp.setOperators(matrices.petsc_matrix(A), matrices.petsc_matrix(P))
    ksp.setType("cg")
    ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
    ksp.getPC().setType("hypre")
    ksp.setTolerances(rtol=1e-8, atol=0.0, max_it=2000)
    bv = PETSc.Vec().createWithArray(b.copy())
    xv = bv.duplicate()
    ksp.solve(bv, xv)
    its = ksp.getIterationNumber() if ksp.getConvergedReason() > 0 else None
    ksp.destroy()
    return its


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dumps", nargs="+")
    ap.add_argument("--eps", default="0,0.01,0.03,0.1,0.3", help="strengths, comma-separated")
    ap.add_argument("--pcs", default="boomeramg,boomeramg_flip,gamg_cb", help="matrices.py preconditioners")
    ap.add_argument("--as-preconditioner", action="store_true", help="also CG on A with BoomerAMG on A + C")
    args = ap.parse_args()
    strengths = [float(e) for e in args.eps.split(",")]
    pcs = args.pcs.split(",")
    print("| dump | n | eps | ||x - x0||_A / ||x0||_A | ||C x|| / ||b|| | " + " | ".join(pcs)
          + (" | CG on A, AMG on A + C | the same, flipped" if args.as_preconditioner else "") + " |")
    print("|---" * (5 + len(pcs) + (2 if args.as_preconditioner else 0)) + "|")
    for folder in args.dumps:
        A, b, layout = read_dump(folder)
        L, pf = face_laplacian(layout)
        unit = np.median(A.diagonal()[pf]) / 24.0
        x0 = spla.spsolve(A.tocsc(), b)
        for eps in strengths:
            C = eps * unit * L
            As = (A + C).tocsr()
            x = spla.spsolve(As.tocsc(), b) if eps > 0 else x0
            change = np.sqrt((x - x0) @ (A @ (x - x0))) / np.sqrt(x0 @ (A @ x0))
            row = [os.path.basename(os.path.normpath(folder)), str(A.shape[0]), f"{eps:g}", f"{change:.2e}",
                   f"{np.linalg.norm(C @ x) / np.linalg.norm(b):.2e}"]
            for pc in pcs:
                row.append(str(matrices.run_pc(As, b, layout, pc, 1e-8, 2000, 1).get("iterations")))
            if args.as_preconditioner:
                row.append(str(cg_on_a_amg_on(A, As, b)))
                row.append(str(cg_on_a_amg_on(A, As, b, dual_cells.parity_signs(layout))))
            print("| " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()
