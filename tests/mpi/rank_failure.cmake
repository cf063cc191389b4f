# mpi.rank_failure: a rank dies after a checkpoint -> the job stops with a message naming the
# rank; a rank aborts on an error -> likewise; the checkpoint still loads and resumes on 2 ranks;
# a rank killed during a stage-2 run, and its checkpoint resumed (bit-exact with an uninterrupted run).
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

run_ranks(RankFailure.KillRankOneAfterACheckpoint out rc)
message(STATUS "killed rank: exit ${rc}\n${out}")
if(rc EQUAL 0)
  message(FATAL_ERROR "the job went on after rank 1 died")
endif()
if(NOT out MATCHES "rank 1")
  message(FATAL_ERROR "the launcher's message does not name rank 1")
endif()

run_ranks(RankFailure.AnErrorOnOneRankAbortsTheJobNamingTheRank out rc)
message(STATUS "aborting rank: exit ${rc}\n${out}")
if(rc EQUAL 0 OR NOT out MATCHES "rank 1 of 2: error: simulated non-finite state")
  message(FATAL_ERROR "an error on rank 1 did not stop the job with its message")
endif()

run_ranks(RankFailure.TheLastCheckpointResumes out rc)
message(STATUS "resume: exit ${rc}\n${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the checkpoint written before the failure did not resume")
endif()

# the same for a stage-2 (train-residual) run
run_ranks(ResidualRankFailure.KillRankOneAfterACheckpoint out rc)
message(STATUS "killed rank, stage 2: exit ${rc}\n${out}")
if(rc EQUAL 0 OR NOT out MATCHES "rank 1")
  message(FATAL_ERROR "the stage-2 job went on after rank 1 died, or the message does not name rank 1")
endif()
run_ranks(ResidualRankFailure.TheLastCheckpointResumes out rc)
message(STATUS "resume, stage 2: exit ${rc}\n${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the stage-2 checkpoint written before the failure did not resume")
endif()
