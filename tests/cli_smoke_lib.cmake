# Helpers of the command-line smoke scripts (include(${CMAKE_CURRENT_LIST_DIR}/../cli_smoke_lib.cmake));
# every one of them runs ${CLI}.
#
# run(DESCRIPTION ARGS...): runs `${CLI} ARGS...`, fails the test unless it exits 0; its standard
# output is left in LAST_OUTPUT.
function(run what)
  execute_process(COMMAND ${CLI} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(LAST_OUTPUT "${out}" PARENT_SCOPE)
endfunction()

# refused(DESCRIPTION REGEX ARGS...): `${CLI} ARGS...` must stop with a clear error — exit status 1
# (a maskadapt::Error) or 105–115 (a flag rejected while parsing), not 0 and not a crash or a
# hang (60 s) — and print something matching REGEX.
function(refused what regex)
  execute_process(COMMAND ${CLI} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)
  if(NOT (rc EQUAL 1 OR (rc GREATER_EQUAL 105 AND rc LESS_EQUAL 115)))
    message(FATAL_ERROR "${what}: exit status '${rc}', expected 1 or a flag error (105-115): ${out}${err}")
  endif()
  if(NOT "${out}${err}" MATCHES "${regex}")
    message(FATAL_ERROR "${what}: the message does not match '${regex}': ${out}${err}")
  endif()
endfunction()

# require_json(FILE): FILE exists and parses as JSON.
function(require_json file)
  if(NOT EXISTS ${file})
    message(FATAL_ERROR "missing ${file}")
  endif()
  file(READ ${file} j)
  string(JSON dummy ERROR_VARIABLE e TYPE "${j}")
  if(e)
    message(FATAL_ERROR "${file} is not JSON: ${e}")
  endif()
endfunction()

# json_field(FILE OUT_VAR KEY...): the value at KEY... of the JSON in FILE.
function(json_field file out_var)
  file(READ ${file} j)
  string(JSON v GET "${j}" ${ARGN})
  set(${out_var} "${v}" PARENT_SCOPE)
endfunction()
