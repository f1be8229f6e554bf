# SIGTERM ends a run cleanly: exit 143, summary.json with status "interrupted by SIGTERM",
# and metrics.csv with the rows up to the interruption (written every frame as the run goes).
set(out ${WORK}/interrupt_out)
file(REMOVE_RECURSE ${out})
execute_process(
  COMMAND sh -c "${IQMPM} run ${SOURCE}/benchmarks/dam_break/dam_break.json --out ${out} --quiet --threads 1 --set write_frames=false --set end_time=5 & pid=$!; sleep 4; kill -TERM $pid; wait $pid"
  RESULT_VARIABLE code ERROR_VARIABLE err)
if(NOT code EQUAL 143)
  message(FATAL_ERROR "expected exit code 143, got ${code}: ${err}")
endif()
file(READ ${out}/summary.json summary)
string(JSON status GET "${summary}" status)
if(NOT status MATCHES "^interrupted by SIGTERM at t = ")
  message(FATAL_ERROR "summary.json status: ${status}")
endif()
file(STRINGS ${out}/metrics.csv rows)
list(LENGTH rows count)
if(count LESS 3)
  message(FATAL_ERROR "metrics.csv has ${count} lines")
endif()
