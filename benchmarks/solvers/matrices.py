#!/usr/bin/python3
"""Preconditioner study on dumped IQ-MPM pressure systems (issue 21).

What it measures
    For every pressure system written by `iqmpm run ... --dump-system STEPS` (system_stepN.mtx,
    rhs_stepN.mtx, layout_stepN.json in a dump folder) it solves A x = b with PETSc CG from a zero
    guess to a relative (unpreconditioned) residual ||b - A x|| / ||b|| <= 1e-8 with each
    preconditioner below, and records CG iterations, setup time (ksp.setUp(), which builds the
    preconditioner) and solve time (ksp.solve()), each the minimum over --repeat fresh builds, and
    the true relative residual of the returned x:
      icc0          ICC(0), natural (layout) order; retried with a positive-definite shift if the
                    factorisation breaks down (the table marks it "s")
      jacobi        diagonal
      gamg          GAMG smoothed aggregation, default near-null space (the constant)
      gamg_cpf      GAMG, near-null space {constant on the p_f rows}
      gamg_cb       GAMG, near-null space {constant on p_f, Q1-P0 checkerboard (-1)^(i+j[+k]) on p_f}
      boomeramg     hypre BoomerAMG, defaults
      boomeramg_t05 hypre BoomerAMG, strong threshold 0.5 (the value advised for 3-D)
      gamg_cb_sor   gamg_cb with SOR (Richardson) smoothing instead of Chebyshev/Jacobi
      boomeramg_hmis  BoomerAMG with the usual 3-D set: HMIS, ext+i, P_max 4, threshold 0.5
      boomeramg_flip  BoomerAMG (defaults) on S A S, S = diag((-1)^(i+j[+k])) of each unknown's
                    dual cell (+1 without one): the same spectrum, but a mode that is a
                    checkerboard times a smooth envelope (the lowest modes of the 3-D systems)
                    becomes smooth, which is what classical AMG coarsening expects
      ml            Trilinos ML, defaults
      ml_flip       ML on S A S
      chol_nd       direct: PETSc Cholesky, nested-dissection order (time reference)
      chol_cholmod  direct: CHOLMOD through PETSc (time reference), when built in
      scipy_splu    direct: scipy SuperLU, added whenever a chol_* is run (needs no PETSc package)
    With --modes K it also computes kappa(D^-1 A) and how many of its K lowest eigenvectors are
    checkerboard-modulated (smoother after multiplying by (-1)^(i+j[+k])).
    A preconditioner missing from the PETSc build, or one that fails, is reported in the table
    (n/a or the failure) instead of stopping the study. With --series it also tabulates how the
    iterations grow per halving of dx over folders of one scene at several resolutions (dx is read
    from each folder's summary.json).

How to run
    /usr/bin/python3 benchmarks/solvers/matrices.py DUMP_DIR [DUMP_DIR ...] --out OUT_DIR \
        [--repeat 3] [--pcs icc0,gamg,...] [--modes 8] [--series "label=DIR1,DIR2,DIR3" ...]
    Writes OUT_DIR/matrices.md (Markdown tables, also printed) and OUT_DIR/matrices.json (raw
    numbers); --from-json OUT_DIR/matrices.json re-writes the tables without solving.
    benchmarks/solvers/study.sh makes the dumps and runs this on them. Run with one thread
    (OMP_NUM_THREADS=1 is set here) and nothing else heavy on the machine: times are wall clock.
"""
import argparse
import glob
import json
import math
import os
import pathlib
import re
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as spla

try:
    import petsc4py
except ImportError:  # Debian installs petsc4py under the PETSc tree; its dist-packages link may be missing
    for cand in sorted(glob.glob("/usr/lib/petscdir/petsc*/*-real/lib/python3/dist-packages")):
        sys.path.append(cand)
    import petsc4py

petsc4py.init([sys.argv[0]])
from petsc4py import PETSc  # noqa: E402

import dual_cells  # noqa: E402  (benchmarks/solvers/dual_cells.py)

# name -> (description, PETSc options); nullspace handled separately for the gamg variants
PRECONDITIONERS = {
    "icc0": ("ICC(0) natural order", {"pc_type": "icc", "pc_factor_levels": 0,
                                      "pc_factor_mat_ordering_type": "natural"}),
    "jacobi": ("Jacobi", {"pc_type": "jacobi"}),
    "gamg": ("GAMG SA, near-null = constant (default)", {"pc_type": "gamg", "pc_gamg_type": "agg"}),
    "gamg_cpf": ("GAMG SA, near-null = const on p_f", {"pc_type": "gamg", "pc_gamg_type": "agg"}),
    "gamg_cb": ("GAMG SA, near-null = const + checkerboard on p_f",
                {"pc_type": "gamg", "pc_gamg_type": "agg"}),
    "boomeramg": ("hypre BoomerAMG, defaults", {"pc_type": "hypre", "pc_hypre_type": "boomeramg"}),
    "boomeramg_t05": ("hypre BoomerAMG, strong threshold 0.5",
                      {"pc_type": "hypre", "pc_hypre_type": "boomeramg",
                       "pc_hypre_boomeramg_strong_threshold": 0.5}),
    "gamg_cb_sor": ("GAMG SA, near-null = const + checkerboard on p_f, SOR smoother",
                    {"pc_type": "gamg", "pc_gamg_type": "agg", "mg_levels_ksp_type": "richardson",
                     "mg_levels_pc_type": "sor"}),
    "boomeramg_hmis": ("hypre BoomerAMG, HMIS coarsening, ext+i interpolation, P_max 4, "
                       "strong threshold 0.5", {"pc_type": "hypre", "pc_hypre_type": "boomeramg",
                                                "pc_hypre_boomeramg_coarsen_type": "HMIS",
                                                "pc_hypre_boomeramg_interp_type": "ext+i",
                                                "pc_hypre_boomeramg_P_max": 4,
                                                "pc_hypre_boomeramg_strong_threshold": 0.5}),
    "boomeramg_flip": ("hypre BoomerAMG, defaults, on S A S (S = checkerboard sign flip)",
                       {"pc_type": "hypre", "pc_hypre_type": "boomeramg"}),
    "ml": ("Trilinos ML, defaults", {"pc_type": "ml"}),
    "ml_flip": ("Trilinos ML, defaults, on S A S (S = checkerboard sign flip)", {"pc_type": "ml"}),
    "chol_nd": ("direct Cholesky (PETSc), ND order",
                {"ksp_type": "preonly", "pc_type": "cholesky", "pc_factor_mat_ordering_type": "nd",
                 "pc_factor_mat_solver_type": "petsc"}),
    "chol_cholmod": ("direct Cholesky (CHOLMOD)",
                     {"ksp_type": "preonly", "pc_type": "cholesky",
                      "pc_factor_mat_solver_type": "cholmod"}),
}


def find_systems(folder):
    """(step, system, rhs, layout) for each dumped step in a folder, by step number."""
    out = []
    for path in pathlib.Path(folder).glob("system_step*.mtx"):
        step = int(re.search(r"system_step(\d+)\.mtx$", path.name).group(1))
        out.append((step, path, path.with_name(f"rhs_step{step}.mtx"),
                    path.with_name(f"layout_step{step}.json")))
    return sorted(out)


def read_system(path):
    """The matrix of a dumped system_stepN.mtx as a full CSR matrix, and whether the file held both
    triangles. `iqmpm run --dump-system` writes both triangles as `general`; its first version
    declared `symmetric` for the same entries, which a reader such as scipy.io.mmread mirrors into
    doubled off-diagonals (an indefinite matrix). So the entries are read as given and mirrored
    only when a `symmetric` file holds one triangle."""
    with open(path) as f:
        header = f.readline().lower().split()
        if header[:3] != ["%%matrixmarket", "matrix", "coordinate"] or header[3] != "real":
            raise ValueError(f"{path}: not a real coordinate Matrix Market file")
        line = f.readline()
        while line.startswith("%"):
            line = f.readline()
        n, m, _ = map(int, line.split())
        data = np.loadtxt(f, ndmin=2)
    i = data[:, 0].astype(np.int64) - 1
    j = data[:, 1].astype(np.int64) - 1
    v = data[:, 2]
    both = bool((i < j).any() and (i > j).any())
    if header[4] == "symmetric" and not both:
        off = i != j
        i, j, v = np.concatenate([i, j[off]]), np.concatenate([j, i[off]]), np.concatenate([v, v[off]])
    return sp.csr_matrix((v, (i, j)), shape=(n, m)), both


def near_null_vectors(layout, kind):
    """Near-null vectors on the p_f block: 'cpf' = constant; 'cb' = constant + Q1-P0 checkerboard."""
    n = layout["unknowns"]
    block = next(b for b in layout["blocks"] if b["name"] == "p_f")
    rows = np.arange(block["offset"], block["offset"] + block["size"])
    const = np.zeros(n)
    const[rows] = 1.0
    vecs = [const]
    if kind == "cb":
        cb = np.zeros(n)
        cb[rows] = dual_cells.parity_signs(layout)[rows]
        vecs.append(cb)
    q, _ = np.linalg.qr(np.column_stack(vecs))  # orthonormalise
    return [q[:, i].copy() for i in range(q.shape[1])]


def spectrum(A, layout, k):
    """The k smallest eigenvalues of D^-1/2 A D^-1/2 (D = diag A), its largest, and how many of
    those k eigenvectors are checkerboard-modulated: smoother (smaller sum of squared differences
    between face-neighbour dual cells) after multiplying by (-1)^(i+j[+k]) than before."""
    d = A.diagonal()
    dm = sp.diags(1.0 / np.sqrt(d))
    S = (dm @ A @ dm).tocsc()
    lo, vecs = spla.eigsh(S, k=k, sigma=0, which="LM")
    hi = spla.eigsh(S, k=1, which="LA", return_eigenvectors=False)[0]
    pairs = dual_cells.face_pairs(layout, np.arange(A.shape[0]))
    sgn = dual_cells.parity_signs(layout)
    n_cb = 0
    for q in range(k):
        v = dm @ vecs[:, q]
        rough = np.sum((v[pairs[0]] - v[pairs[1]]) ** 2)
        w = sgn * v
        rough_cb = np.sum((w[pairs[0]] - w[pairs[1]]) ** 2)
        n_cb += int(rough_cb < rough)
    lo = np.sort(lo)
    return {"lambda_min": float(lo[0]), "lambda_max": float(hi), "kappa": float(hi / lo[0]),
            "lowest": [float(x) for x in lo], "checkerboard_modes": n_cb, "k": k}


def petsc_matrix(A):
    M = PETSc.Mat().createAIJ(size=A.shape, csr=(A.indptr.astype(PETSc.IntType),
                                                  A.indices.astype(PETSc.IntType), A.data))
    M.assemble()
    M.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    M.setOption(PETSc.Mat.Option.SPD, True)
    return M


def solve_once(A, b, layout, name, rtol, max_it, shift):
    """Build a fresh Mat/KSP, set up and solve; returns the record of this attempt."""
    desc, options = PRECONDITIONERS[name]
    if name.endswith("_flip"):  # solve (S A S) y = S b, x = S y: same iterations as on A itself
        sgn = dual_cells.parity_signs(layout)
        A = (sp.diags(sgn) @ A @ sp.diags(sgn)).tocsr()
        b = sgn * b
    M = petsc_matrix(A)
    if name.startswith("gamg_c"):
        vecs = []
        for v in near_null_vectors(layout, "cb" if name.startswith("gamg_cb") else "cpf"):
            pv = M.createVecLeft()
            pv.setArray(v)
            vecs.append(pv)
        M.setNearNullSpace(PETSc.NullSpace().create(constant=False, vectors=vecs))
    prefix = f"s_{name}_"
    opts = PETSc.Options(prefix)
    full = {"ksp_type": "cg", "ksp_norm_type": "unpreconditioned", **options}
    if full["ksp_type"] == "preonly":
        full["ksp_norm_type"] = "none"
    if shift:
        full["pc_factor_shift_type"] = "positive_definite"
    for k, v in full.items():
        opts[k] = v
    ksp = PETSc.KSP().create()
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(M)
    ksp.setTolerances(rtol=rtol, atol=0.0, max_it=max_it)
    ksp.setInitialGuessNonzero(False)
    ksp.setFromOptions()
    bv = M.createVecLeft()
    bv.setArray(b)
    xv = M.createVecRight()
    try:
        t0 = time.perf_counter()
        ksp.setUp()
        t1 = time.perf_counter()
        ksp.solve(bv, xv)
        t2 = time.perf_counter()
        reason = ksp.getConvergedReason()
        its = ksp.getIterationNumber()
        x = xv.getArray().copy()
        res = float(np.linalg.norm(b - A @ x) / np.linalg.norm(b))  # = that of S x on A when flipped
        rec = {"iterations": its if options.get("ksp_type") != "preonly" else 0,
               "setup_ms": 1e3 * (t1 - t0), "solve_ms": 1e3 * (t2 - t1), "reason": int(reason),
               "converged": reason > 0 and res <= 10 * rtol, "true_residual": res, "shift": shift,
               "error": None}
        if name.startswith("gamg"):
            rec["levels"] = ksp.getPC().getMGLevels()
    except PETSc.Error as err:
        rec = {"iterations": None, "setup_ms": None, "solve_ms": None, "reason": None,
               "converged": False, "true_residual": None, "shift": shift,
               "error": f"PETSc error {err.ierr}"}
    finally:
        for k in full:
            opts.delValue(k)
        ksp.destroy()
        M.destroy()
    return rec


def available(name):
    """Whether the PETSc build has what the preconditioner needs (None if yes, else a reason)."""
    pc_type = PRECONDITIONERS[name][1]["pc_type"]
    pc = PETSc.PC().create()
    try:
        pc.setType(pc_type)
    except PETSc.Error:
        return f"pc_type {pc_type} not in this PETSc build"
    finally:
        pc.destroy()
    return None


def run_pc(A, b, layout, name, rtol, max_it, repeat):
    why = available(name)
    if why:
        return {"available": False, "error": why, "converged": False}
    shift = False
    best = None
    for _ in range(repeat):
        rec = solve_once(A, b, layout, name, rtol, max_it, shift)
        if name == "icc0" and not shift and (rec["error"] or rec["reason"] == -11 or not rec["converged"]):
            shift = True  # ICC(0) broke down (zero or negative pivot): retry with a shift
            rec = solve_once(A, b, layout, name, rtol, max_it, shift)
        if rec["error"] or not rec["converged"]:
            best = rec
            break
        if best is None or rec["setup_ms"] + rec["solve_ms"] < best["setup_ms"] + best["solve_ms"]:
            best = rec
    best["available"] = True
    return best


def scipy_direct(A, b, repeat):
    """scipy SuperLU (COLAMD order) as a direct-solve reference that needs no PETSc package."""
    best = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        lu = spla.splu(A.tocsc())
        t1 = time.perf_counter()
        x = lu.solve(b)
        t2 = time.perf_counter()
        rec = {"iterations": 0, "setup_ms": 1e3 * (t1 - t0), "solve_ms": 1e3 * (t2 - t1),
               "true_residual": float(np.linalg.norm(b - A @ x) / np.linalg.norm(b)),
               "converged": True, "available": True, "shift": False, "error": None}
        if best is None or rec["setup_ms"] + rec["solve_ms"] < best["setup_ms"] + best["solve_ms"]:
            best = rec
    return best


def describe(folder, step, A, layout):
    summ = pathlib.Path(folder) / "summary.json"
    s = json.loads(summ.read_text()) if summ.exists() else {}
    scene = s.get("scene", {})
    wall = scene.get("fluid", {}).get("wall_constraint", "auto")
    blocks = {blk["name"]: blk["size"] for blk in layout["blocks"]}
    if wall == "auto":
        wall = "faces" if "y" in blocks else "corners"
    d = A.diagonal()
    asym = abs(A - A.T).max() / abs(A).max()
    return {"label": f"{pathlib.Path(folder).name}/step{step}", "folder": str(folder), "step": step,
            "scene": s.get("scene_name"), "dim": len(layout["cells"]), "dx": s.get("dx"),
            "wall_constraint": wall, "cells": layout["cells"], "n": A.shape[0], "nnz": A.nnz,
            "blocks": blocks, "min_diag": float(d.min()), "rel_asymmetry": float(asym)}


def fmt(x, digits=1):
    return "-" if x is None else f"{x:.{digits}f}"


def cell(rec, key, direct=False):
    if not rec.get("available", True):
        return "n/a"
    if rec.get("error"):
        return "fail"
    if not rec["converged"]:
        if key != "iterations":
            return "-"
        return "PC failed" if rec.get("reason") == -11 else f"no conv ({rec['iterations']})"
    if key == "iterations":
        if direct:
            return "direct"
        return f"{rec['iterations']}{' s' if rec.get('shift') else ''}"
    value = rec["setup_ms"] + rec["solve_ms"] if key == "total_ms" else rec[key]
    return fmt(value, 1 if value < 100 else 0)


def growth_rows(results, series, pcs):
    """Iteration growth per halving of dx over each --series (label=DIR1,DIR2,... coarse to fine):
    one row per preconditioner, one column per series, "its / its / its (growth, growth)"."""
    by_folder = {}
    for r in results:
        by_folder.setdefault(os.path.realpath(r["matrix"]["folder"]), r)
    labels, columns = [], []
    for spec in series:
        label, dirs = spec.split("=", 1)
        runs = [by_folder.get(os.path.realpath(d)) for d in dirs.split(",")]
        if any(r is None for r in runs):
            print(f"warning: series {label}: a folder is not in the study", file=sys.stderr)
            continue
        dxs = [r["matrix"]["dx"] for r in runs]
        labels.append(f"{label} (dx " + " / ".join(f"{d:g}" for d in dxs) + ")")
        col = {}
        for pc in pcs:
            its = [r["pcs"][pc].get("iterations") if r["pcs"][pc].get("converged") else None
                   for r in runs]
            steps = []
            for (d0, i0), (d1, i1) in zip(zip(dxs, its), zip(dxs[1:], its[1:])):
                ok = i0 and i1 and d0 and d1
                steps.append(f"{(i1 / i0) ** (1 / math.log2(d0 / d1)):.2f}" if ok else "-")
            col[pc] = (" / ".join("-" if i is None else str(i) for i in its)
                       + " (" + ", ".join(steps) + ")")
        columns.append(col)
    lines = ["| preconditioner | " + " | ".join(labels) + " |", "|---|" + "---|" * len(labels)]
    for pc in pcs:
        lines.append(f"| {pc} | " + " | ".join(c[pc] for c in columns) + " |")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folders", nargs="*", help="dump folders (each holds system_stepN.mtx ...)")
    ap.add_argument("--out", required=True, help="output folder for matrices.md and matrices.json")
    ap.add_argument("--rtol", type=float, default=1e-8, help="relative residual target (1e-8)")
    ap.add_argument("--max-it", type=int, default=5000, help="CG iteration cap (5000)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="fresh set-up + solve per preconditioner; times are the fastest (3)")
    ap.add_argument("--pcs", default=",".join(PRECONDITIONERS),
                    help="comma-separated subset of: " + ", ".join(PRECONDITIONERS))
    ap.add_argument("--modes", type=int, default=0,
                    help="also compute the K lowest modes of diag-scaled A: kappa and how many "
                         "are checkerboard-modulated (0: skip)")
    ap.add_argument("--series", action="append", default=[],
                    help="label=DIR1,DIR2,DIR3 (coarse to fine): iteration growth per halving of dx")
    ap.add_argument("--from-json", metavar="FILE",
                    help="no solves: re-write the tables from a matrices.json of an earlier study")
    args = ap.parse_args()
    if not args.folders and not args.from_json:
        ap.error("give dump folders or --from-json")
    pcs = [p for p in args.pcs.split(",") if p]
    for p in pcs:
        if p not in PRECONDITIONERS:
            ap.error(f"unknown preconditioner {p}")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    results = []
    if args.from_json:
        old = json.loads(pathlib.Path(args.from_json).read_text())
        results = old["results"]
        pcs = [p for p in old["preconditioners"] if p in pcs]
        args.rtol, args.repeat = old["rtol"], old["repeat"]
    for folder in args.folders:
        systems = find_systems(folder)
        if not systems:
            print(f"warning: no system_step*.mtx in {folder}", file=sys.stderr)
        for step, sysf, rhsf, layf in systems:
            A, both = read_system(sysf)
            b = np.asarray(scipy.io.mmread(str(rhsf))).ravel()
            layout = json.loads(layf.read_text())
            info = describe(folder, step, A, layout)
            info["file_has_both_triangles"] = both
            A = ((A + A.T) * 0.5).tocsr()  # remove round-off asymmetry (see rel_asymmetry)
            if args.modes > 0:
                info["spectrum"] = spectrum(A, layout, min(args.modes, A.shape[0] - 2))
            print(f"{info['label']}: n = {info['n']}, nnz = {info['nnz']}, blocks {info['blocks']}",
                  file=sys.stderr, flush=True)
            recs = {}
            for pc in pcs:
                recs[pc] = run_pc(A, b, layout, pc, args.rtol, args.max_it, args.repeat)
                r = recs[pc]
                print(f"  {pc:14s} its {r.get('iterations')} setup {fmt(r.get('setup_ms'), 2)} ms "
                      f"solve {fmt(r.get('solve_ms'), 2)} ms res {r.get('true_residual')} "
                      f"{r.get('error') or ''}", file=sys.stderr, flush=True)
            if any(pc.startswith("chol") for pc in pcs):
                recs["scipy_splu"] = scipy_direct(A, b, args.repeat)
            results.append({"matrix": info, "pcs": recs})

    cols = pcs + (["scipy_splu"] if any(pc.startswith("chol") for pc in pcs) else [])
    lines = [f"CG to ||b - Ax|| / ||b|| <= {args.rtol:g} from x = 0; times: fastest of {args.repeat} "
             "fresh set-ups (ms, wall clock, one thread). `s`: ICC(0) needed a positive-definite "
             "shift. n/a: not in this PETSc build; fail: set-up or solve error; PC failed: "
             "the preconditioner broke down in the solve; no conv: "
             f"not converged in {args.max_it} iterations.", "",
             "| matrix | dim | walls | dx | n | nnz | blocks | kappa(D^-1 A) | checkerboard among lowest modes |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        m = r["matrix"]
        blocks = ", ".join(f"{k} {v}" for k, v in m["blocks"].items())
        sp_ = m.get("spectrum")
        kap = f"{sp_['kappa']:.3g}" if sp_ else "-"
        ncb = f"{sp_['checkerboard_modes']} of {sp_['k']}" if sp_ else "-"
        lines.append(f"| {m['label']} | {m['dim']} | {m['wall_constraint']} | {m['dx']} | {m['n']} "
                     f"| {m['nnz']} | {blocks} | {kap} | {ncb} |")
    for key, title in (("iterations", "CG iterations"), ("setup_ms", "Set-up (ms)"),
                       ("solve_ms", "Solve (ms)"), ("total_ms", "Set-up + solve (ms)")):
        lines += ["", f"**{title}**", "", "| matrix | " + " | ".join(cols) + " |",
                  "|---|" + "---|" * len(cols)]
        for r in results:
            lines.append(f"| {r['matrix']['label']} | "
                         + " | ".join(cell(r["pcs"][c], key, c.startswith(("chol", "scipy")))
                                      for c in cols) + " |")
    if args.series:
        lines += ["", "**Iteration growth per halving of dx**: iterations coarse / middle / fine "
                  "(growth per halving between consecutive resolutions, "
                  "(its ratio)^(1 / log2(dx ratio)))", ""]
        lines += growth_rows(results, args.series, [p for p in pcs if not p.startswith("chol")])
    failures = [(r["matrix"]["label"], c, r["pcs"][c].get("error") or
                 ("PC failed (KSP reason -11)" if r["pcs"][c].get("reason") == -11 else "not converged"))
                for r in results for c in cols
                if r["pcs"][c].get("available", True) and not r["pcs"][c].get("converged")]
    if failures:
        lines += ["", "Failures: " + "; ".join(f"{m} {c}: {e}" for m, c, e in failures)]
    table = "\n".join(lines) + "\n"
    (out / "matrices.md").write_text(table)
    if args.from_json:
        (out / "matrices.md").write_text(table)
        print(table)
        return
    (out / "matrices.json").write_text(json.dumps(
        {"rtol": args.rtol, "repeat": args.repeat, "petsc": ".".join(map(str, PETSc.Sys.getVersion())),
         "preconditioners": {k: {"description": PRECONDITIONERS[k][0], "options": PRECONDITIONERS[k][1]}
                             for k in pcs}, "results": results}, indent=1))
    print(table)


if __name__ == "__main__":
    main()
