"""Table of elastic-gate runs against the experiment of Antoci et al. (2007).

usage: summarize.py OUT_DIR RUN [RUN ...]   (each RUN a folder OUT_DIR/RUN with metrics.csv
and summary.json). Errors are those of benchmarks.md: the peak of the tip's horizontal
displacement against the experiment's, and the relative L2 error of each component over the
experiment's ten times (the run interpolated there; both series start from zero, the
digitised offset of the first point removed as in the data file's note).
"""
import csv
import json
import pathlib
import sys

import numpy as np

DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "antoci2007_elastic_gate_tip_displacement.csv"


def experiment(component):
    rows = [r for r in csv.DictReader(l for l in DATA.open() if not l.startswith("#"))
            if r["series"] == "experiment" and r["component"] == component]
    t = np.array([float(r["t_s"]) for r in rows])
    d = np.array([float(r["disp_m"]) for r in rows])
    return t, d - d[0]


def main():
    out = pathlib.Path(sys.argv[1])
    tx, dx_exp = experiment("x")
    ty, dy_exp = experiment("y")
    print("| run | peak tip dx (m) [exp 0.0463] | peak error | rel. L2 dx | rel. L2 dy | force at 0.1 s (N/m) | volume drift | steps | wall (s) | largest stages (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in sys.argv[2:]:
        run = out / name
        summary = json.loads((run / "summary.json").read_text())
        rows = list(csv.DictReader((run / "metrics.csv").open()))
        col = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
        t = col["t"]
        if summary["status"] != "ok" or t[-1] < tx[-1]:
            print(f"| {name} | {summary['status']} | | | | | | | | |")
            continue
        sx = np.interp(tx, t, col["gate_tip_dx"])
        sy = np.interp(ty, t, col["gate_tip_dy"])
        peak = col["gate_tip_dx"].max()
        near = (t > 0.09) & (t < 0.11)
        stages = sorted(summary["stage_seconds"].items(), key=lambda kv: -kv[1])[:3]
        print(f"| {name} | {peak:.4f} | {100 * (peak / dx_exp.max() - 1):+.1f} % "
              f"| {100 * np.linalg.norm(sx - dx_exp) / np.linalg.norm(dx_exp):.1f} % "
              f"| {100 * np.linalg.norm(sy - dy_exp) / np.linalg.norm(dy_exp):.1f} % "
              f"| {col['gate_force_x'][near].mean():.1f} | {100 * summary['volume_drift']:+.1f} % "
              f"| {summary['steps']} | {summary['wall_time_s']:.1f} "
              f"| {', '.join(f'{k} {v:.1f}' for k, v in stages)} |")


if __name__ == "__main__":
    main()
