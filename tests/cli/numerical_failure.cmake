# A numerical failure stops the run with a diagnosis: exit code 3, summary.json with a
# status naming the cause, and the metrics up to the failure. Here the fluid is thrown at a
# side that has no wall, so particles leave the domain.
set(out ${WORK}/failure_out)
file(REMOVE_RECURSE ${out})
execute_process(COMMAND ${IQMPM} run ${SOURCE}/benchmarks/hydrostatic/hydrostatic_2d.json --out ${out} --quiet
                        --set dx=0.0625 --set end_time=1 --set walls.x+=none --set fluid.initial_velocity=[2,0]
                RESULT_VARIABLE code ERROR_VARIABLE err OUTPUT_VARIABLE stdout)
if(NOT code EQUAL 3)
  message(FATAL_ERROR "expected exit code 3, got ${code}: ${err}")
endif()
file(READ ${out}/summary.json summary)
string(JSON status GET "${summary}" status)
if(NOT status MATCHES "left the domain through side x\\+")
  message(FATAL_ERROR "summary.json status lacks the diagnosis: ${status}")
endif()
if(NOT EXISTS ${out}/metrics.csv)
  message(FATAL_ERROR "metrics.csv up to the failure is missing")
endif()
