#!/usr/bin/python3
"""In-solver PCG iterations against resolution (issue 21: "3-D: mean iterations per solve at most
30 on the fine cube and growing at most 1.3x per halving of dx").

What it measures
    Short full runs (not dumps) of the solver binary, one thread each, one after another, at three
    resolutions per series; for each run it reads summary.json: linear_iterations (mean / max per
    pressure solve), steps and the solve stage time; then the growth of the mean per halving of dx,
    (mean_fine / mean_coarse)^(1 / log2(dx_coarse / dx_fine)).
    Series (scene files under benchmarks/):
      3d_tank0.6   floating_block_3d_fine.json (tank 0.6 x 0.75 x 0.6 m, dt_max 0.625 ms) at
                   dx 0.1 / 0.05 / 0.025 (dx 0.1 needs a domain height of 0.8 m: 0.75 m is 7.5
                   cells), to t = --end-3d (0.1 s), PCG with IC(0), warm start (the defaults)
      3d_tank0.6_cold  the same with solver.warm_start = none (zero first guess, as in matrices.py)
      3d_tank1     floating_block_3d.json (tank 1 x 0.75 x 1 m, dt_max 5 ms) at dx 0.125 / 0.05 to
                   t = 0.1 s, then the 0.025 run of 3d_tank0.6 (the fine cube scene): the
                   resolutions of the scene files as they are (not exact halvings, other tank)
      2d_faces     dam_break.json at dx 0.009125 / 0.0045625 / 0.00228125, solver.method = pcg
                   (IC(0)), to t = --end-2d (0.2 s), walls as in 2-D by default (faces)
      2d_corners   the same with fluid.wall_constraint = corners

    Preconditioner variants (--variants; each series runs once per variant, in that order):
      ic0          the scene's defaults (PCG with IC(0) where the series asks for PCG)
      amg          solver.preconditioner = boomeramg, solver.amg_checkerboard_flip = off
      amg_flip     solver.preconditioner = boomeramg, solver.amg_checkerboard_flip = on
    --set KEY=VALUE adds a scene setting to every run (e.g. a BoomerAMG parameter) and --label
    names that set-up in the run folders and the table.

How to run (from the repository root; ~5 min on one core per variant)
    /usr/bin/python3 benchmarks/solvers/insolver.py --bin build/iqmpm --out out/solvers/insolver
    [--series 3d_tank0.6,2d_faces] [--variants ic0,amg_flip] [--set KEY=VALUE --label NAME]
    [--end-3d 0.1] [--end-2d 0.2] [--reuse]
    Writes OUT/insolver.md (Markdown table, also printed) and OUT/insolver.json; the runs' own
    output folders are OUT/runs/<series>[_<variant>][_<label>]_dx<dx>.
"""
import argparse
import json
import math
import pathlib
import subprocess
import sys

VARIANTS = {
    "ic0": [],
    "amg": ["solver.preconditioner=boomeramg", "solver.amg_checkerboard_flip=off"],
    "amg_flip": ["solver.preconditioner=boomeramg", "solver.amg_checkerboard_flip=on"],
}

B3 = "benchmarks/floating_block_3d/"
B2 = "benchmarks/dam_break/dam_break.json"


def series_table(end3, end2):
    fine = B3 + "floating_block_3d_fine.json"
    # The fine cube as measured (2026-12-01 to 12-03): dt_max 0.625 ms, no position correction.
    as_measured = ["dt_max=0.000625", "experimental.position_correction=0"]
    tall = ["domain.max=[0.6,0.8,0.6]"] + as_measured
    return {
        "3d_tank0.6": [(fine, 0.1, tall + [f"end_time={end3}"]),
                       (fine, 0.05, as_measured + [f"end_time={end3}"]),
                       (fine, 0.025, as_measured + [f"end_time={end3}"])],
        "3d_tank0.6_cold": [(fine, 0.1, tall + [f"end_time={end3}", "solver.warm_start=none"]),
                            (fine, 0.05, as_measured + [f"end_time={end3}", "solver.warm_start=none"]),
                            (fine, 0.025, as_measured + [f"end_time={end3}", "solver.warm_start=none"])],
        "3d_tank1": [(B3 + "floating_block_3d.json", 0.125, [f"end_time={end3}"]),
                     (B3 + "floating_block_3d.json", 0.05, [f"end_time={end3}"]),
                     (fine, 0.025, as_measured + [f"end_time={end3}"])],
        "2d_faces": [(B2, dx, [f"end_time={end2}", "solver.method=pcg"])
                     for dx in (0.009125, 0.0045625, 0.00228125)],
        "2d_corners": [(B2, dx, [f"end_time={end2}", "solver.method=pcg",
                                 "fluid.wall_constraint=corners"])
                       for dx in (0.009125, 0.0045625, 0.00228125)],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/iqmpm", help="solver binary (build/iqmpm)")
    ap.add_argument("--out", default="out/solvers/insolver", help="output folder")
    ap.add_argument("--series", default="3d_tank0.6,3d_tank0.6_cold,3d_tank1,2d_faces,2d_corners",
                    help="comma-separated series names (see the header)")
    ap.add_argument("--end-3d", type=float, default=0.1, help="end time of the 3-D runs (0.1 s)")
    ap.add_argument("--end-2d", type=float, default=0.2, help="end time of the 2-D runs (0.2 s)")
    ap.add_argument("--variants", default="ic0", help="comma-separated preconditioner variants (see the header)")
    ap.add_argument("--set", action="append", default=[], dest="extra",
                    help="KEY=VALUE added to every run (repeatable)")
    ap.add_argument("--label", default="", help="name of the --set set-up in run folders and the table")
    ap.add_argument("--reuse", action="store_true",
                    help="keep a run whose folder already has summary.json (re-tabulate only)")
    args = ap.parse_args()
    table = series_table(args.end_3d, args.end_2d)
    out = pathlib.Path(args.out)
    (out / "runs").mkdir(parents=True, exist_ok=True)

    done = {}  # identical runs shared between series (the fine cube of 3d_tank1 and 3d_tank0.6)
    results = {}
    suffix = f"_{args.label}" if args.label else ""
    for variant in args.variants.split(","):
        for name in args.series.split(","):
            rows = []
            for scene, dx, sets in table[name]:
                sets = sets + VARIANTS[variant] + args.extra
                key = (scene, dx, tuple(sets))
                if key not in done:
                    tag = name if variant == "ic0" else f"{name}_{variant}"
                    folder = out / "runs" / f"{tag}{suffix}_dx{dx}"
                    cmd = [args.bin, "run", scene, "-o", str(folder), "-q", "-j1",
                           "--set", f"dx={dx}", "--set", "write_frames=false"]
                    for s in sets:
                        cmd += ["--set", s]
                    if not (args.reuse and (folder / "summary.json").exists()):
                        print(" ".join(cmd), file=sys.stderr, flush=True)
                        subprocess.run(cmd, check=True)
                    s = json.loads((folder / "summary.json").read_text())
                    done[key] = {"scene": scene, "dx": dx, "sets": sets, "folder": str(folder),
                                 "steps": s["steps"], "solves": s["steps"] * s["pressure_solves"]["mean"],
                                 "t_final": s.get("t_final"),
                                 "linear_solver": s["linear_solver"],
                                 "iterations": s["linear_iterations"],
                                 "solve_s": s["stage_seconds"].get("solve", 0.0),
                                 "wall_s": s["wall_time_s"], "unknowns_max": s.get("active_cells_max"),
                                 "command": " ".join(cmd)}
                rows.append(done[key])
            results[(name, variant + suffix)] = rows

    lines = ["| series | preconditioner | dx (m) | steps | mean its | max its | ms per solve | growth of mean per halving |",
             "|---|---|---|---|---|---|---|---|"]
    for (name, variant), rows in results.items():
        prev = None
        for r in rows:
            mean = r["iterations"]["mean"]
            growth = "-"
            if prev and prev["iterations"]["mean"] > 0 and mean > 0:
                growth = f"{(mean / prev['iterations']['mean']) ** (1 / math.log2(prev['dx'] / r['dx'])):.2f}"
            lines.append(f"| {name} | {variant} | {r['dx']:g} | {r['steps']} | {mean:.1f} | {r['iterations']['max']} "
                         f"| {1e3 * r['solve_s'] / max(r['solves'], 1):.2f} | {growth} |")
            prev = r
    text = "\n".join(lines) + "\n"
    (out / "insolver.md").write_text(text)
    (out / "insolver.json").write_text(json.dumps({f"{n} {v}": rows for (n, v), rows in results.items()}, indent=1))
    print(text)


if __name__ == "__main__":
    main()
