# Shared by the CLI-on-ranks scripts (train_base_cli.cmake, train_residual_cli.cmake).
# `run(out rc COMMAND…)`: runs a command (240 s at most) and returns its stdout + stderr and exit code.
function(run out_var rc_var)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 240)
  set(${out_var} "${out}${err}" PARENT_SCOPE)
  set(${rc_var} "${rc}" PARENT_SCOPE)
endfunction()

# A run on 2 ranks × 2 envs of `command` (train-base, train-residual) that exited 0, reported the
# layout, and printed its closing line once (rank 0 alone prints).
function(expect_two_rank_run command rc out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "mpirun -np 2 ${command} failed")
  endif()
  if(NOT out MATCHES "2 ranks x 2 envs")
    message(FATAL_ERROR "rank 0 did not report the layout")
  endif()
  string(REGEX MATCHALL "${command}: done" done "${out}")
  list(LENGTH done ndone)
  if(NOT ndone EQUAL 1)
    message(FATAL_ERROR "expected one rank (0) to print, found ${ndone} '${command}: done' lines")
  endif()
endfunction()

# `file` has `n` lines (a log that rank 0 alone writes).
function(expect_lines file n)
  file(STRINGS ${file} lines)
  list(LENGTH lines got)
  if(NOT got EQUAL n)
    message(FATAL_ERROR "${file}: ${got} lines, expected ${n} (rank 0 writes the log)")
  endif()
endfunction()

# A refusal: a non-zero exit whose output matches `regex`.
function(expect_refusal rc out regex what)
  if(rc EQUAL 0 OR NOT out MATCHES "${regex}")
    message(FATAL_ERROR "${what} was not refused with a clear error")
  endif()
endfunction()
