# docs/scene_keys.md must be exactly what docs/generate_scene_keys.py makes from the output
# of `iqmpm keys` (one source of truth: the scene reader in mpm/scene/scene.cpp). On failure
# the script prints the difference and the command that regenerates the page.
execute_process(COMMAND ${PYTHON} ${SOURCE}/docs/generate_scene_keys.py --iqmpm ${IQMPM} --check
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE code)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "${out}${err}docs/generate_scene_keys.py --check failed (${code})")
endif()
