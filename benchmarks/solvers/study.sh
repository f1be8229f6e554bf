#!/usr/bin/env bash
# Preconditioner study of issue 21 on real pressure systems: dumps the system of one step of the
# 3-D floating cube and of the 2-D dam break at three resolutions each (--dump-system), runs
# matrices.py on the dumps (CG + ICC(0) / Jacobi / GAMG / BoomerAMG / ML, direct Cholesky) and
# insolver.py (in-solver IC(0) PCG iterations in short full runs). One thread, one run at a time.
#   benchmarks/solvers/study.sh [OUT_DIR]          (default out/solvers/study; ~10 min)
#   IQMPM_BIN=/path/to/iqmpm benchmarks/solvers/study.sh ...   (default build/iqmpm)
#   REUSE=1 benchmarks/solvers/study.sh ...   keeps dumps and runs already in OUT_DIR (re-tabulate)
# 3-D dumps: step 20 (t = 0.1 s with dt_max 5 ms in the 1 m tank, 0.0125 s with 0.625 ms in the
# 0.6 m tank of the fine cube). 2-D dumps: the last step before t = 0.2 s, the same physical time at
# every dx (steps 70 / 140 / 278 with the binary of 2026-12-01; check summary.json "steps" if the
# time stepping changes).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
out=${1:-out/solvers/study}
bin=${IQMPM_BIN:-build/iqmpm}
py=/usr/bin/python3
d=$out/dumps
mkdir -p "$d"
B3=benchmarks/floating_block_3d
common=(--set write_frames=false -q -j1)
# The fine cube as the dumps of 2026-12-01 to 12-03 were taken: dt_max 0.625 ms, no position correction
# (the scene has 2.5 ms and the correction since 2026-12-03).
fine_as_measured=(--set dt_max=0.000625 --set experimental.position_correction=0)
reuse=${REUSE:-0}
run() {  # run SCENE -o FOLDER ARGS...: skipped when REUSE=1 and FOLDER already has summary.json
  if [[ $reuse == 1 && -f $3/summary.json ]]; then return; fi
  "$bin" run "$@"
}

# 3-D, walls on corners (the 3-D default); the fine cube also with wall-face multipliers
run $B3/floating_block_3d.json -o "$d/cube3d_dx0.125_corners" --set dx=0.125 --set end_time=0.101 --dump-system 20 "${common[@]}"
run $B3/floating_block_3d.json -o "$d/cube3d_dx0.05_corners" --set end_time=0.101 --dump-system 20 "${common[@]}"
run $B3/floating_block_3d_fine.json -o "$d/fine3d_dx0.1_corners" --set dx=0.1 --set 'domain.max=[0.6,0.8,0.6]' --set end_time=0.013 --dump-system 20 "${fine_as_measured[@]}" "${common[@]}"
run $B3/floating_block_3d_fine.json -o "$d/fine3d_dx0.05_corners" --set dx=0.05 --set end_time=0.013 --dump-system 20 "${fine_as_measured[@]}" "${common[@]}"
for wc in corners faces; do
  run $B3/floating_block_3d_fine.json -o "$d/fine3d_dx0.025_$wc" --set fluid.wall_constraint=$wc --set end_time=0.013 --dump-system 20 "${fine_as_measured[@]}" "${common[@]}"
done
# 2-D dam break, both wall treatments
for wc in corners faces; do
  for pair in 0.009125:70 0.0045625:140 0.00228125:278; do
    dx=${pair%%:*}; step=${pair##*:}
    run benchmarks/dam_break/dam_break.json -o "$d/db2d_dx${dx}_$wc" --set dx=$dx --set end_time=0.2 --set fluid.wall_constraint=$wc --dump-system $step "${common[@]}"
  done
done

$py benchmarks/solvers/matrices.py --out "$out/matrices" --repeat 3 --modes 8 \
  "$d"/cube3d_dx0.125_corners "$d"/cube3d_dx0.05_corners \
  "$d"/fine3d_dx0.1_corners "$d"/fine3d_dx0.05_corners "$d"/fine3d_dx0.025_corners "$d"/fine3d_dx0.025_faces \
  "$d"/db2d_dx0.009125_corners "$d"/db2d_dx0.0045625_corners "$d"/db2d_dx0.00228125_corners \
  "$d"/db2d_dx0.009125_faces "$d"/db2d_dx0.0045625_faces "$d"/db2d_dx0.00228125_faces \
  --series "3d_tank0.6=$d/fine3d_dx0.1_corners,$d/fine3d_dx0.05_corners,$d/fine3d_dx0.025_corners" \
  --series "3d_tank1=$d/cube3d_dx0.125_corners,$d/cube3d_dx0.05_corners,$d/fine3d_dx0.025_corners" \
  --series "2d_corners=$d/db2d_dx0.009125_corners,$d/db2d_dx0.0045625_corners,$d/db2d_dx0.00228125_corners" \
  --series "2d_faces=$d/db2d_dx0.009125_faces,$d/db2d_dx0.0045625_faces,$d/db2d_dx0.00228125_faces"

$py benchmarks/solvers/insolver.py --bin "$bin" --out "$out/insolver" $([[ $reuse == 1 ]] && echo --reuse)
