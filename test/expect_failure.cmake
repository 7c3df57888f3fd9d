# ctest helper: runs PROGRAM --check WORLD and passes when it exits non-zero with a message that
# matches the regular expression EXPECTED.
execute_process(COMMAND ${PROGRAM} --check ${WORLD} RESULT_VARIABLE status OUTPUT_VARIABLE out
                ERROR_VARIABLE err)
if(status EQUAL 0)
  message(FATAL_ERROR "expected a failure for ${WORLD}, got exit code 0: ${out}")
endif()
if(NOT err MATCHES "${EXPECTED}")
  message(FATAL_ERROR "the message does not name '${EXPECTED}': ${err}")
endif()
message(STATUS "refused as expected (exit code ${status}): ${err}")
