#!/usr/bin/env bash
# Run time of two solver binaries side by side, in one sitting (issue 21's figures): the
# fine floating cube over its first 0.3 s (at dt_max 0.625 ms without the position
# correction, as issue 21's figures were taken), the elastic sphere in full, and the dam break at
# a/128 in full, each binary in turn, the same threads. Writes each run to OUT/<case>_<a|b>
# and a table of wall time, stage times and mean solver iterations to OUT/side_by_side.md.
#   benchmarks/solvers/side_by_side.sh BIN_A BIN_B [OUT] [THREADS]
# e.g. build the commit before a change into /tmp/before/iqmpm, then
#   benchmarks/solvers/side_by_side.sh /tmp/before/iqmpm build/iqmpm out/side_by_side 2
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
a=${1:?binary A}; b=${2:?binary B}; out=${3:-out/side_by_side}; threads=${4:-2}
mkdir -p "$out"
cases=(
  "cube_fine|benchmarks/floating_block_3d/floating_block_3d_fine.json|--set end_time=0.3 --set dt_max=0.000625 --set experimental.position_correction=0"
  "sphere|benchmarks/elastic_sphere/elastic_sphere.json|"
  "dam_a128|benchmarks/dam_break/dam_break.json|--set dx=0.001140625"
)
for entry in "${cases[@]}"; do
  IFS='|' read -r name scene extra <<< "$entry"
  for side in a b; do
    bin=$a; [[ $side == b ]] && bin=$b
    # shellcheck disable=SC2086
    "$bin" run "$scene" --out "$out/${name}_$side" --quiet --threads "$threads" --set write_frames=false $extra
  done
done
/usr/bin/python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
lines = ["| case | A wall (s) | B wall (s) | A / B | A solve (s) | B solve (s) | A newton (s) | B newton (s) | A iterations | B iterations | steps A / B |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
for name in ("cube_fine", "sphere", "dam_a128"):
    s = {side: json.loads((out / f"{name}_{side}" / "summary.json").read_text()) for side in "ab"}
    st = {side: s[side]["stage_seconds"] for side in "ab"}
    lines.append(f"| {name} | {s['a']['wall_time_s']:.1f} | {s['b']['wall_time_s']:.1f} | "
                 f"{s['a']['wall_time_s'] / s['b']['wall_time_s']:.2f} | {st['a'].get('solve', 0):.1f} | {st['b'].get('solve', 0):.1f} | "
                 f"{st['a'].get('newton', 0):.1f} | {st['b'].get('newton', 0):.1f} | "
                 f"{s['a']['linear_iterations']['mean']:.1f} | {s['b']['linear_iterations']['mean']:.1f} | {s['a']['steps']} / {s['b']['steps']} |")
table = "\n".join(lines)
(out / "side_by_side.md").write_text(table + "\n")
print(table)
PY
