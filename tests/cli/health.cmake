# Health checks after every step (docs/method.md#health-checks; issue 24).
# 1. The elastic gate at dt_max = 1 ms created energy every few steps (0.36-0.45 of the run's
#    energy scale in one step) and never opened: its steps are now taken again with half the
#    dt, counted in summary.json, and the run ends ok. With no retries allowed it stops
#    (exit 3) naming the energy.
# 2. A heavy, soft floating block (rho_s 10 000, E 10 kPa) tears apart: the run stops
#    (exit 3) naming the body and the pieces, instead of ending ok.
set(gate ${SOURCE}/benchmarks/elastic_gate/elastic_gate.json)
set(out ${WORK}/health_gate)
file(REMOVE_RECURSE ${out})
execute_process(COMMAND ${IQMPM} run ${gate} --out ${out} --quiet --threads 2 --set write_frames=false
                        --set dt_max=1e-3 --set end_time=0.06
                RESULT_VARIABLE code ERROR_VARIABLE err)
file(READ ${out}/summary.json summary)
string(JSON retries GET "${summary}" dt_retries)
if(NOT code EQUAL 0 OR retries LESS 1 OR NOT err MATCHES "created mechanical energy.*taking it again with dt = 0.0005 s")
  message(FATAL_ERROR "gate at dt_max 1 ms: exit ${code}, dt_retries ${retries}, stderr: ${err}")
endif()

# Without retries it stops at the first such step; `--dump-system` of that step writes the
# failed attempt's pressure system (stepN_failed1), for a study of the failure offline.
string(REGEX MATCH "step ([0-9]+) at t = [^\n]*created mechanical energy" first_failure "${err}")
set(failed_step ${CMAKE_MATCH_1})
set(out ${WORK}/health_gate_no_retry)
file(REMOVE_RECURSE ${out})
execute_process(COMMAND ${IQMPM} run ${gate} --out ${out} --quiet --threads 2 --set write_frames=false
                        --set dt_max=1e-3 --set end_time=0.06 --set health.max_retries=0 --dump-system ${failed_step}
                RESULT_VARIABLE code ERROR_VARIABLE err)
file(READ ${out}/summary.json summary)
string(JSON status GET "${summary}" status)
if(NOT code EQUAL 3 OR NOT status MATCHES "step ${failed_step}: the step created mechanical energy")
  message(FATAL_ERROR "gate at dt_max 1 ms without retries: exit ${code}, status: ${status}")
endif()
foreach(part system rhs)
  if(NOT EXISTS ${out}/${part}_step${failed_step}_failed1.mtx)
    message(FATAL_ERROR "gate without retries: no ${part}_step${failed_step}_failed1.mtx of the failed step")
  endif()
endforeach()
file(READ ${out}/layout_step${failed_step}_failed1.json layout)
string(JSON unknowns GET "${layout}" unknowns)
file(STRINGS ${out}/system_step${failed_step}_failed1.mtx size_line REGEX "^[0-9]+ [0-9]+ [0-9]+$")
if(NOT size_line MATCHES "^${unknowns} ${unknowns} ")
  message(FATAL_ERROR "gate without retries: the dumped system (${size_line}) is not the layout's ${unknowns} unknowns")
endif()

# A step that fails before its pressure system is assembled (the solid's Newton step, held
# to 3 iterations) has no system of its own: `--dump-system` of it writes nothing, with a
# warning, rather than the previous step's system under this step's name.
set(out ${WORK}/health_newton_dump)
file(REMOVE_RECURSE ${out})
set(beam ${SOURCE}/benchmarks/stability/soft_beam.json)
set(newton_args --set write_frames=false --set newton.max_iterations=3 --set health.max_retries=0 --set end_time=0.1)
execute_process(COMMAND ${IQMPM} run ${beam} --out ${out} --quiet --threads 2 ${newton_args}
                RESULT_VARIABLE code ERROR_VARIABLE err)
file(READ ${out}/summary.json summary)
string(JSON status GET "${summary}" status)
if(NOT code EQUAL 3 OR NOT status MATCHES "step ([0-9]+): solid Newton step did not converge")
  message(FATAL_ERROR "soft beam at 3 Newton iterations: exit ${code}, status: ${status}")
endif()
set(newton_step ${CMAKE_MATCH_1})
if(newton_step LESS 2)
  message(FATAL_ERROR "soft beam at 3 Newton iterations failed at step ${newton_step}: no earlier system to leave behind")
endif()
file(REMOVE_RECURSE ${out})
execute_process(COMMAND ${IQMPM} run ${beam} --out ${out} --threads 2 ${newton_args} --dump-system ${newton_step}
                RESULT_VARIABLE code ERROR_VARIABLE err)
if(NOT code EQUAL 3 OR EXISTS ${out}/system_step${newton_step}_failed1.mtx
   OR NOT err MATCHES "attempt 1 failed before its pressure system was assembled")
  message(FATAL_ERROR "Newton failure with --dump-system ${newton_step}: exit ${code}, stderr: ${err}")
endif()

set(out ${WORK}/health_tear)
file(REMOVE_RECURSE ${out})
execute_process(COMMAND ${IQMPM} run ${SOURCE}/benchmarks/floating_block/floating_block.json --out ${out} --quiet --threads 2
                        --set write_frames=false --set end_time=0.5 --set cfl=0.2 --set dt_max=1e-3
                        --set solids.0.density=10000 --set solids.0.youngs_modulus=1e4
                RESULT_VARIABLE code ERROR_VARIABLE err)
file(READ ${out}/summary.json summary)
string(JSON status GET "${summary}" status)
if(NOT code EQUAL 3 OR NOT status MATCHES "solid 'block' came apart: [0-9]+ pieces")
  message(FATAL_ERROR "torn block: exit ${code}, status: ${status}")
endif()

# 3. The 12 GPa plate with its lumped mass in the solve (docs/method.md#solid-response)
#    changes its volume far beyond what its bulk modulus allows under the water's load: with
#    the energy check switched off, the body-volume check stops it (exit 3) naming the body.
set(out ${WORK}/health_plate_volume)
file(REMOVE_RECURSE ${out})
execute_process(COMMAND ${IQMPM} run ${SOURCE}/benchmarks/submerged_block/submerged_plate.json --out ${out} --quiet
                        --threads 2 --set write_frames=false --set experimental.solid_response=mass
                        --set health.energy_growth=1e9 --set health.max_retries=0
                RESULT_VARIABLE code ERROR_VARIABLE err)
file(READ ${out}/summary.json summary)
string(JSON status GET "${summary}" status)
if(NOT code EQUAL 3 OR NOT status MATCHES "solid 'gate' changed its volume by [0-9.]+ %, more than its stiffness allows")
  message(FATAL_ERROR "plate with the mass response: exit ${code}, status: ${status}")
endif()
# With the plate's stiffness in the solve (the scene as it is) the same run ends ok, every
# step's constraint residual in steps.csv at the direct solver's round-off.
set(out ${WORK}/health_plate)
file(REMOVE_RECURSE ${out})
execute_process(COMMAND ${IQMPM} run ${SOURCE}/benchmarks/submerged_block/submerged_plate.json --out ${out} --quiet
                        --threads 2 --set write_frames=false --set health.max_retries=0
                RESULT_VARIABLE code)
file(STRINGS ${out}/steps.csv rows)
list(GET rows 0 header)
string(REPLACE "," ";" header "${header}")
list(FIND header constraint_residual column)
list(LENGTH rows count)
math(EXPR last "${count} - 1")
foreach(i RANGE 1 ${last})
  list(GET rows ${i} row)
  string(REPLACE "," ";" row "${row}")
  list(GET row ${column} residual)
  if(residual GREATER_EQUAL 1e-10 OR NOT residual MATCHES "^[0-9.e+-]+$")
    message(FATAL_ERROR "plate: step ${i} constraint_residual ${residual} (expected below 1e-10)")
  endif()
endforeach()
if(NOT code EQUAL 0 OR column LESS 0 OR count LESS 10)
  message(FATAL_ERROR "plate: exit ${code}, constraint_residual column ${column}, ${count} rows")
endif()
