#!/usr/bin/env bash
# Runs the solver on the scenes of one MPMNet family, writing each run's
# pressure_fields.h5 (mpmnet/README.md, "Dataset"), and the family's split file
# DATA_DIR/FAMILY/split.json: train, validation and test by scene and resolution, never
# by steps of one run. Usage:
#   bash mpmnet/make_dataset.sh FAMILY DATA_DIR [IQMPM_BIN]
# FAMILY: dam_break, floating_block or floating_block_3d. One folder per run under
# DATA_DIR/FAMILY, named scene_dxVALUE. A run already complete (summary.json with status
# ok) is kept. The test runs are the unseen runs of benchmarks/warm_start/run.sh.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
usage="usage: make_dataset.sh dam_break|floating_block|floating_block_3d DATA_DIR [IQMPM_BIN]"
family=${1:?$usage}
data=${2:?$usage}
bin=${3:-build/iqmpm}
[[ -x $bin ]] || { echo "make_dataset: no solver at $bin (bash .ci/setup.sh builds it)" >&2; exit 2; }
declare -A split=([train]="" [validation]="" [test]="")

run() {  # split scene dx end_time [--set ...]
  local which=$1 scene=$2 dx=$3 end=$4; shift 4
  local name out
  name=$(basename "$scene" .json)_dx${dx}
  out=$data/$family/$name
  split[$which]+="${split[$which]:+, }\"$name\""
  if [[ -f $out/summary.json ]] && grep -q '"status": "ok"' "$out/summary.json" && [[ -f $out/pressure_fields.h5 ]]; then
    echo "make_dataset: $name done already"; return
  fi
  echo "make_dataset: $name ($which; dx $dx, end_time $end)"
  "$bin" run "$scene" --out "$out" --quiet --set dx="$dx" --set end_time="$end" \
    --set write_pressure_fields=true --set write_frames=false "$@"
}

case $family in
  dam_break)
    # The obstacle's runs bring the ghost pressure and interface fields.
    run train benchmarks/dam_break/dam_break.json 0.009125 0.6
    run train benchmarks/dam_break/dam_break.json 0.0045625 0.6
    run train benchmarks/dam_break_obstacle/dam_break_obstacle.json 0.009125 0.6
    run validation benchmarks/dam_break_obstacle/dam_break_obstacle.json 0.006083333333333333 0.6
    run test benchmarks/dam_break/dam_break.json 0.006083333333333333 0.6
    run test benchmarks/dam_break_obstacle/dam_break_obstacle.json 0.0045625 0.6
    ;;
  floating_block)
    run train benchmarks/floating_block/floating_block.json 0.02 1.0
    run train benchmarks/floating_block/floating_block.json 0.01 1.0
    run train benchmarks/floating_block/floating_block_roll.json 0.01 1.0
    run validation benchmarks/floating_block/floating_block_light.json 0.01 1.0
    run test benchmarks/floating_block/floating_block.json 0.0125 1.0
    run test benchmarks/submerged_block/submerged_block.json 0.0125 1.0
    ;;
  floating_block_3d)
    run train benchmarks/floating_block_3d/floating_block_3d.json 0.125 1.0
    run train benchmarks/floating_block_3d/floating_block_3d.json 0.0625 1.0
    run validation benchmarks/floating_block_3d/floating_block_3d.json 0.08333333333333333 1.0
    run test benchmarks/floating_block_3d/floating_block_3d.json 0.05 1.0
    ;;
  *) echo "make_dataset: unknown family '$family'; accepted: dam_break, floating_block, floating_block_3d" >&2; exit 2 ;;
esac
cat > "$data/$family/split.json" <<JSON
{"format": "iqmpm-mpmnet-split", "format_version": 1,
 "description": "the $family family of mpmnet/make_dataset.sh",
 "train": [${split[train]}],
 "validation": [${split[validation]}],
 "test": [${split[test]}]}
JSON
echo "make_dataset: $data/$family/split.json"
