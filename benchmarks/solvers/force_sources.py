#!/usr/bin/python3
"""Where a step's interface force comes from: the force on the solids, traced to the rows of the
pressure system's right-hand side that drive it (issue 23 item 3).

What it computes
    For each dumped step (`iqmpm run ... --dump-system N`: system_stepN.mtx, rhs_stepN.mtx,
    constraint_stepN.mtx, layout_stepN.json) the force of the water on the solids along one axis,
    as the solver measures it (docs/method.md#interface-force): f = g . lambda with A lambda = r,
    g_i = -sum of row i of D over the solids' entries along the axis, for the coupling rows (h;
    p_f where fluid corners move with a solid; p_a, trapped air against a solid), zero for the
    others (p_g, y). Since A is
    symmetric, f = w . r with A w = g: row i contributes w_i r_i, its right-hand side (the
    constraint's defect before the projection, D v*) times the force's sensitivity to it. The
    rows with the largest contributions are listed with their block and dual cell, and marked
    `new` where the previous step (when it was dumped too) had no unknown of that block there:
    a cell that turns from empty to fluid, whose defect the projection removes in one step.
    The force is the sum over every solid (the dump does not say which node is whose): use it
    on scenes with one body. With --metrics the run's probe is shown beside the total, with
    their difference (round-off on a scene with one body).

How to run
    build/iqmpm run benchmarks/dam_break_obstacle/dam_break_obstacle.json -o R \\
        --set write_frames=false --dump-system 964,965,966
    /usr/bin/python3 benchmarks/solvers/force_sources.py R [--axis 0] [--top 10] \\
        [--metrics R/metrics.csv --probe obstacle_force_x] [--json OUT.json]
    One thread; a 2-D system of a few thousand unknowns takes a second (two sparse LU solves).
"""
import argparse
import csv
import json
import os
import re
import sys

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.io  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402

import dual_cells  # noqa: E402  (benchmarks/solvers/dual_cells.py)

COUPLING_BLOCKS = ("h", "p_f", "p_a")


def fail(message):
    """Bad input: the message on stderr, exit code 2."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def dumped_steps(folder):
    """Step labels with every file the analysis needs (failed attempts included), in order."""
    steps = []
    for name in os.listdir(folder):
        m = re.fullmatch(r"constraint_step(\d+)(_failed\d+)?\.mtx", name)
        if m and all(os.path.exists(os.path.join(folder, f"{kind}_step{m.group(1)}{m.group(2) or ''}.{ext}"))
                     for kind, ext in (("system", "mtx"), ("rhs", "mtx"), ("layout", "json"))):
            steps.append((int(m.group(1)), m.group(2) or ""))
    return [f"{n}{suffix}" for n, suffix in sorted(steps)]


def load(folder, label):
    read = lambda kind: scipy.io.mmread(os.path.join(folder, f"{kind}_step{label}.mtx"))  # noqa: E731
    with open(os.path.join(folder, f"layout_step{label}.json")) as f:
        layout = json.load(f)
    missing = [key for key in ("solid_velocity_entries", "dual_cells") if key not in layout]
    if missing:
        fail(f"{folder}/layout_step{label}.json lacks {', '.join(missing)}: dumped by an older iqmpm "
             "(--dump-system writes them since 2026-12-05)")
    return read("system").tocsc(), np.ravel(np.asarray(read("rhs"))), read("constraint").tocsr(), layout


def block_of_rows(layout, size):
    names = np.full(size, "", dtype=object)
    for block in layout["blocks"]:
        names[block["offset"]:block["offset"] + block["size"]] = block["name"]
    return names


def sources(A, r, D, layout, axis):
    """(force, contribution per row, block per row): f = sum of the contributions w_i r_i."""
    dim = len(layout["cells"])
    solid = layout["solid_velocity_entries"]
    blocks = block_of_rows(layout, A.shape[0])
    g = np.zeros(A.shape[0])
    rows = D.shape[0]
    on_solid_axis = np.asarray(D[:, axis:solid:dim].sum(axis=1)).ravel()
    coupling = np.isin(blocks[:rows], COUPLING_BLOCKS)
    g[:rows] = np.where(coupling, -on_solid_axis, 0.0)
    solve = spla.factorized(A)
    force = float(g @ solve(r))
    contribution = solve(g) * r
    return force, contribution, blocks


def probe_by_step(path, probe):
    """metrics.csv's column `probe`, row n = after step n (row 0: the start)."""
    with open(path) as f:
        rows = list(csv.DictReader(f))
    if not rows or probe not in rows[0]:
        fail(f"{path} has no column '{probe}' (columns: {', '.join(rows[0]) if rows else 'none'})")
    return [float(row[probe]) for row in rows]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", help="a run folder with --dump-system files")
    parser.add_argument("--axis", type=int, default=0, help="force component (default 0: x)")
    parser.add_argument("--top", type=int, default=10, help="rows listed per step (default 10)")
    parser.add_argument("--metrics", help="the run's metrics.csv, to show a probe beside the total")
    parser.add_argument("--probe", default="", help="with --metrics: the solid_force probe's column")
    parser.add_argument("--json", help="write the figures here as JSON")
    args = parser.parse_args(argv)
    if not os.path.isdir(args.folder):
        fail(f"{args.folder} is not a folder")
    labels = dumped_steps(args.folder)
    if not labels:
        fail(f"no complete dump in {args.folder} (system, rhs, constraint and layout files of one step)")
    if args.metrics and not args.probe:
        fail("--metrics needs --probe (the solid_force probe's column in metrics.csv)")
    reference = probe_by_step(args.metrics, args.probe) if args.metrics else None
    cells_of = {}
    results = []
    for label in labels:
        A, r, D, layout = load(args.folder, label)
        dim = len(layout["cells"])
        if not 0 <= args.axis < dim:
            fail(f"--axis {args.axis}: accepted 0 to {dim - 1} (the scene is {dim}-D)")
        force, contribution, blocks = sources(A, r, D, layout, args.axis)
        dual = layout["dual_cell"]
        cells_of[label] = {(blocks[i], dual[i]) for i in range(len(dual)) if dual[i] >= 0}
        previous = cells_of.get(str(int(re.match(r"\d+", label).group()) - 1))
        step = {"step": label, "force": force, "by_block": {}, "rows": []}
        for name in dict.fromkeys(b for b in blocks if b):
            step["by_block"][name] = float(contribution[blocks == name].sum())
        for i in np.argsort(-np.abs(contribution))[:args.top]:
            step["rows"].append({"row": int(i), "block": blocks[i], "cell": dual_cells.cell_index(layout, dual[i]) if dual[i] >= 0 else None,
                                 "rhs": float(r[i]), "contribution": float(contribution[i]),
                                 "new": None if previous is None else (blocks[i], dual[i]) not in previous})
        line = f"step {label}: force {force:.6g}"
        if reference is not None and "_failed" not in label:
            n = int(label)
            if n >= len(reference):
                fail(f"{args.metrics} ends before step {n}")
            step["probe"] = reference[n]
            line += f" (probe {reference[n]:.6g}, difference {force - reference[n]:.2g})"
        print(line + "; sources by block: " + ", ".join(f"{k} {v:.4g}" for k, v in step["by_block"].items()))
        for row in step["rows"]:
            new = {None: "", True: "  new", False: ""}[row["new"]]
            print(f"    {row['block']:4s} cell {row['cell']}  rhs {row['rhs']:10.3e}  force {row['contribution']:10.4g}{new}")
        results.append(step)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
