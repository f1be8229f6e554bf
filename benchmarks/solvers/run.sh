#!/usr/bin/env bash
# Linear-solver comparison on the 2-D dam break (issue: "measure which is fastest on the dam
# break at two resolutions"): every method at dx = a/32 and a/64, in the same session,
# writing a table of wall time, solve time, time per solve and CG iterations.
#   benchmarks/solvers/run.sh [OUT_DIR] [END_TIME]      (defaults: out/solvers, 0.6 s)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
out=${1:-out/solvers}
end_time=${2:-0.6}
bin=${IQMPM_BIN:-build/iqmpm}
mkdir -p "$out"
for dx in 0.0045625 0.00228125; do
  for method in cholmod ldlt pcg; do
    "$bin" run benchmarks/dam_break/dam_break.json --out "$out/dx${dx}_${method}" --quiet \
      --set dx=$dx --set end_time="$end_time" --set write_frames=false --set solver.method=$method
  done
done
/usr/bin/python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
rows = []
for run in sorted(out.glob("dx*_*")):
    s = json.loads((run / "summary.json").read_text())
    solve = s["stage_seconds"].get("solve", 0.0)
    rows.append((s["dx"], s["linear_solver"], s["wall_time_s"], solve, 1e3 * solve / max(s["steps"], 1),
                 s["linear_iterations"]["mean"], s["steps"], s["active_cells_max"]))
lines = ["| dx (m) | solver | wall (s) | solve (s) | ms per solve | mean CG iterations | steps | max unknowns |",
         "|---|---|---|---|---|---|---|---|"]
lines += [f"| {r[0]:.6g} | {r[1]} | {r[2]:.1f} | {r[3]:.1f} | {r[4]:.2f} | {r[5]:.1f} | {r[6]} | {r[7]} |" for r in rows]
table = "\n".join(lines)
(out / "solvers.md").write_text(table + "\n")
print(table)
PY
