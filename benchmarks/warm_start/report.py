#!/usr/bin/env python3
"""Tabulates benchmarks/warm_start/run.sh's runs: per case and warm start, the mean
iterations per solve and the solve-stage seconds (solve plus warm start), each against
`previous` (today's default), and whether the run's final metrics equal the cold start's;
plots iterations against time step per case. Usage: report.py OUT"""
import csv
import json
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

WARM_STARTS = ("none", "previous", "extrapolate", "projection", "learned")


def read_steps(run):
    with open(run / "steps.csv") as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def metric_scales(run):
    """Largest magnitude of each metrics.csv column over a run (the scale of its differences)."""
    with open(run / "metrics.csv") as f:
        rows = list(csv.DictReader(f))
    scales = {}
    for key in rows[0] if rows else []:
        values = [abs(float(r[key])) for r in rows if r[key] not in ("", "nan", "inf", "-inf")]
        scales[key] = max(values) if values else 0.0
    return scales


def main(out):
    out = pathlib.Path(out)
    lines = ["# Warm starts of the pressure solve (benchmarks/warm_start/run.sh)", "",
             "Median first residual: |b - A x0| / |b| of the guess x0 (1 for none; the solve stops at 1e-8). Solve stage = the PCG solve plus the warm start (Map, inference, Invmap, projection). "
             "Ratios against `previous`: iterations and solve-stage time of previous / this one (above 1: this one is better). "
             "`metrics vs none`: the largest difference of a final metric from the cold start's, relative to that metric's "
             "largest magnitude over the cold start's run, and its name. `rejected guesses`: guesses that were not finite, "
             "replaced by the last solution.", ""]
    for case in sorted(p for p in out.iterdir() if p.is_dir()):
        runs = {w: case / w for w in WARM_STARTS if (case / w / "steps.csv").is_file()}
        if "previous" not in runs:
            continue
        summary = {w: json.loads((r / "summary.json").read_text()) for w, r in runs.items()}
        scale = metric_scales(runs.get("none", runs["previous"]))
        steps = {w: read_steps(r) for w, r in runs.items()}
        stats = {}
        for w, rows in steps.items():
            its = sum(r["iterations"] for r in rows) / len(rows)
            residuals = sorted(r["initial_residual"] for r in rows)
            median_residual = residuals[len(residuals) // 2]
            solve = sum(r["solve_s"] + r["warm_start_s"] for r in rows)
            guess = sum(r["warm_start_s"] for r in rows)
            stats[w] = (its, solve, guess, len(rows), median_residual)
        base_its, base_solve = stats["previous"][0], stats["previous"][1]
        cold = summary.get("none", {}).get("final_metrics", {})
        lines += [f"## {case.name}", "",
                  "| warm start | status | steps | mean iterations | median first residual | solve stage (s) | of which warm start (s) | iterations: previous / this | solve stage: previous / this | metrics vs none | rejected guesses |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for w in WARM_STARTS:
            if w not in stats:
                continue
            its, solve, guess, n, median_residual = stats[w]
            final = summary[w].get("final_metrics", {})
            worst, worst_key = 0.0, ""
            for key, value in final.items():
                if key in cold and value is not None and cold[key] is not None and scale.get(key, 0) > 0:
                    difference = abs(value - cold[key]) / scale[key]
                    if difference > worst:
                        worst, worst_key = difference, key
            rejected = summary[w].get("rejected_warm_starts", 0)
            lines.append(f"| {w} | {summary[w]['status'][:30]} | {n} | {its:.1f} | {median_residual:.1e} | {solve:.2f} | {guess:.2f} | "
                         f"{base_its / its:.2f} | {base_solve / solve:.2f} | {worst:.1e} {worst_key} | {rejected} |")
        lines.append("")
        fig, ax = plt.subplots(figsize=(8, 4))
        for w, rows in steps.items():
            ax.plot([r["step"] for r in rows], [r["iterations"] for r in rows], lw=0.8, label=w)
        ax.set_xlabel("time step")
        ax.set_ylabel("PCG iterations")
        ax.set_title(case.name)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / f"{case.name}.png", dpi=110)
        plt.close(fig)
        lines += [f"![{case.name}]({case.name}.png)", ""]
    (out / "report.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
