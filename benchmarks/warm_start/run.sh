#!/usr/bin/env bash
# Warm starts of the pressure solve side by side, in one sitting (issue 22): every
# solver.warm_start on runs MPMNet was not trained on (mpmnet/splits/*.json, "test"),
# with the iterative solve (solver.method = pcg). Writes OUT/<case>/<warm_start>/ and
# OUT/report.md with the mean iterations and solve-stage seconds (the solve plus the warm
# start: Map, inference, Invmap, projection) of each, and OUT/<case>.png, iterations
# against time step.
#   benchmarks/warm_start/run.sh [OUT] [THREADS] [IQMPM_BIN]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
out=${1:-out/warm_start}; threads=${2:-2}; bin=${3:-build/iqmpm}
[[ -x $bin ]] || { echo "warm_start: no solver at $bin (bash .ci/setup.sh builds it)" >&2; exit 2; }
mkdir -p "$out"
# case | scene | model of its family | overrides (the unseen resolution or scene)
cases=(
  "dam_break_a24|benchmarks/dam_break/dam_break.json|mpmnet/models/dam_break_2d.pt|--set dx=0.006083333333333333 --set end_time=0.6"
  "dam_break_obstacle_a32|benchmarks/dam_break_obstacle/dam_break_obstacle.json|mpmnet/models/dam_break_2d.pt|--set end_time=0.6"
  "floating_block_dx0.0125|benchmarks/floating_block/floating_block.json|mpmnet/models/floating_block_2d.pt|--set dx=0.0125 --set end_time=1.0"
  "submerged_block|benchmarks/submerged_block/submerged_block.json|mpmnet/models/floating_block_2d.pt|--set end_time=1.0"
  "floating_block_3d|benchmarks/floating_block_3d/floating_block_3d.json|mpmnet/models/floating_block_3d.pt|--set end_time=1.0"
)
for entry in "${cases[@]}"; do
  IFS='|' read -r name scene model extra <<< "$entry"
  for warm in none previous extrapolate projection learned; do
    args=()
    if [[ $warm == learned ]]; then
      [[ -f $model ]] || { echo "warm_start: $name: no model $model, learned skipped"; continue; }
      args=(--set solver.model="$model")
    fi
    echo "warm_start: $name, $warm"
    # shellcheck disable=SC2086
    # A run that fails (exit 3) is reported with its status; the others go on.
    "$bin" run "$scene" --out "$out/$name/$warm" --quiet --threads "$threads" --set write_frames=false \
      --set solver.method=pcg --set solver.warm_start="$warm" "${args[@]}" $extra || echo "warm_start: $name, $warm exited $?"
  done
done
/usr/bin/python3 benchmarks/warm_start/report.py "$out"
