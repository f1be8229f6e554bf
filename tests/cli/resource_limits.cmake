# Scenes too large for the solver are refused before anything is allocated or written
# (exit 2, no output folder): past the 32-bit indices (the dam break at dx = 2e-5, which
# wrapped into "no particle was seeded"), past the memory limit, past the output limit
# (end_time 1e6 at frame_rate 1e3, a billion frames). The limits are the user's to raise,
# and `check` prints both estimates.
set(dam ${SOURCE}/benchmarks/dam_break/dam_break.json)
function(expect_refused name pattern)
  file(REMOVE_RECURSE ${WORK}/${name})
  execute_process(COMMAND ${IQMPM} run ${dam} --out ${WORK}/${name} -q ${ARGN} RESULT_VARIABLE code ERROR_VARIABLE err OUTPUT_VARIABLE out)
  if(NOT code EQUAL 2 OR NOT err MATCHES "${pattern}")
    message(FATAL_ERROR "${name}: exit ${code}, stderr: ${err}")
  endif()
  if(EXISTS ${WORK}/${name})
    message(FATAL_ERROR "${name}: a refused scene must not create its output folder")
  endif()
endfunction()
expect_refused(index_limit_out "scene key 'dx' = 2e-05: .*32-bit indices.*accepted: dx >=" --set dx=2e-5)
expect_refused(memory_limit_out "estimated [0-9.]+ GiB of memory, more than the limit of 2 GiB.*'dx'.*'particles_per_axis'.*--max-memory"
               --set dx=1e-4 --max-memory 2)
expect_refused(output_limit_out "estimated [0-9.e+]+ .iB of output, more than the limit of 20 GiB.*'end_time'.*'frame_rate'.*--max-output"
               --set end_time=1e6 --set frame_rate=1e3 --max-memory 100000)
# Raised limits let the same scenes through `check`, which prints the estimates.
execute_process(COMMAND ${IQMPM} check ${dam} --set dx=1e-4 --max-memory 1000 --max-output 100 RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code EQUAL 0 OR NOT out MATCHES "valid.*estimated peak memory [0-9.]+ GiB.*estimated output")
  message(FATAL_ERROR "check with raised limits: exit ${code}, stdout: ${out}, stderr: ${err}")
endif()
execute_process(COMMAND ${IQMPM} check ${dam} --set end_time=1e6 --set frame_rate=1e3 --max-memory 100000 --max-output 1e9
                RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT code EQUAL 0 OR NOT out MATCHES "estimated output [0-9.e+]+ GiB \\(.*, 1e\\+09 frames")
  message(FATAL_ERROR "check with --max-output 1e9: exit ${code}, stdout: ${out}, stderr: ${err}")
endif()
