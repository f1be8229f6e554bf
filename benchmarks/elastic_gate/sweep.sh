#!/usr/bin/env bash
# Elastic-gate studies (issue #4): three resolutions (dx = 5, 2.5, 1.25 mm; dt_max scaled
# with dx), the published stiffness band (E = 7.8 and 12 MPa) and the ghost-matrix
# stiffness lambda_g (1e3, 1e5 = default, 1e7 Pa) and the bilateral interface (the scene's
# is unilateral), all against the experiment of Antoci et
# al. (2007). Writes OUT/table.md: peak tip displacement, relative L2 errors of both
# components over the experiment's times, wall time and per-stage seconds.
#   benchmarks/elastic_gate/sweep.sh [OUT_DIR] [THREADS]     (defaults: out/elastic_gate_sweep, 2)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
out=${1:-out/elastic_gate_sweep}
threads=${2:-2}
bin=${IQMPM_BIN:-build/iqmpm}
scene=benchmarks/elastic_gate/elastic_gate.json
mkdir -p "$out"
run() {  # name, then --set overrides
  local name=$1; shift
  local sets=()
  for kv in "$@"; do sets+=(--set "$kv"); done
  echo "== $name" >&2
  "$bin" run "$scene" --out "$out/$name" --quiet --threads "$threads" --set write_frames=false "${sets[@]}"
}
run dx5mm dx=0.005 dt_max=0.0002
run dx2.5mm
run dx1.25mm dx=0.00125 dt_max=0.00005
run E7.8MPa solids.0.youngs_modulus=7.8e6
run lambda_g_1e3 solids.0.ghost_stiffness=1e3
run lambda_g_1e7 solids.0.ghost_stiffness=1e7
run bilateral coupling.interface=bilateral
/usr/bin/python3 benchmarks/elastic_gate/summarize.py "$out" dx5mm dx2.5mm dx1.25mm E7.8MPa lambda_g_1e3 lambda_g_1e7 bilateral | tee "$out/table.md"
