# mpi.rank_failure: a rank aborts on an error -> the job stops with its message naming the rank;
# a rank dies after a checkpoint (stage 1, RankFailure; stage 2, ResidualRankFailure) -> the
# launcher stops the job and names the rank, and the checkpoint still loads and resumes on 2 ranks
# (stage 2: bit-exactly as an uninterrupted run).
# -DMPIEXEC=… -DFLAGS=… -DTESTS=<maskadapt_tests_mpi> -DOUT=<dir>
file(REMOVE_RECURSE "${OUT}")
file(MAKE_DIRECTORY "${OUT}")
function(run_ranks filter out_var rc_var)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env MASKADAPT_MPI_FAULT_DIR=${OUT}
                          ${MPIEXEC} ${FLAGS} -np 2 ${TESTS} --gtest_filter=${filter}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
  set(${out_var} "${out}${err}" PARENT_SCOPE)
  set(${rc_var} "${rc}" PARENT_SCOPE)
endfunction()

run_ranks(RankFailure.AnErrorOnOneRankAbortsTheJobNamingTheRank out rc)
message(STATUS "aborting rank: exit ${rc}\n${out}")
if(rc EQUAL 0 OR NOT out MATCHES "rank 1 of 2: error: simulated non-finite state")
  message(FATAL_ERROR "an error on rank 1 did not stop the job with its message")
endif()

# `suite`.KillRankOneAfterACheckpoint must stop the job naming rank 1, and
# `suite`.TheLastCheckpointResumes must then pass.
function(expect_kill_then_resume suite)
  run_ranks(${suite}.KillRankOneAfterACheckpoint out rc)
  message(STATUS "${suite}, killed rank: exit ${rc}\n${out}")
  if(rc EQUAL 0)
    message(FATAL_ERROR "${suite}: the job went on after rank 1 died")
  endif()
  if(NOT out MATCHES "rank 1")
    message(FATAL_ERROR "${suite}: the launcher's message does not name rank 1")
  endif()
  run_ranks(${suite}.TheLastCheckpointResumes out rc)
  message(STATUS "${suite}, resume: exit ${rc}\n${out}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${suite}: the checkpoint written before the failure did not resume")
  endif()
endfunction()
expect_kill_then_resume(RankFailure)
expect_kill_then_resume(ResidualRankFailure)
