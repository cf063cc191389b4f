# mpi.train_residual_cli: `mpirun -np 2 maskadapt train-residual` end to end (see CMakeLists.txt):
# a one-process base, composition (ours) on 2 ranks, a resume on 2 ranks, the location task on 2
# ranks, and the refusals: one process on the 2-rank checkpoint, 3 envs on 2 ranks, and a command
# that does not run distributed.
# -DMPIEXEC=… -DFLAGS=… -DCLI=… -DCONFIG=… -DOUT=…
file(REMOVE_RECURSE "${OUT}")
include(${CMAKE_CURRENT_LIST_DIR}/mpi_cli_lib.cmake)
set(tiny --config ${CONFIG} --threads 1 --envs 4 --hidden 16 --episode-seconds 1)

run(out rc ${CLI} train-base --config ${CONFIG} --iterations 1 --envs 2 --threads 1 --motions walk --out ${OUT}/base)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the base run failed:\n${out}")
endif()
set(BASE ${OUT}/base/checkpoint.bin)

run(out rc ${MPIEXEC} ${FLAGS} -np 2 ${CLI} train-residual --task composition --method ours --base ${BASE}
    --new-motion kick --masks lower_body arms --switch-rate 1 --iterations 2 ${tiny} --out ${OUT}/comp)
message(STATUS "composition, 2 ranks, 2 iterations: exit ${rc}\n${out}")
expect_two_rank_run(train-residual "${rc}" "${out}")
expect_lines(${OUT}/comp/log.jsonl 2)

run(out rc ${MPIEXEC} ${FLAGS} -np 2 ${CLI} train-residual --resume ${OUT}/comp/checkpoint.bin --iterations 3 --out ${OUT}/comp)
message(STATUS "2 ranks, resume to 3: exit ${rc}\n${out}")
if(NOT rc EQUAL 0 OR NOT out MATCHES "resumed at iteration 2")
  message(FATAL_ERROR "the 2-rank checkpoint did not resume on 2 ranks")
endif()
expect_lines(${OUT}/comp/log.jsonl 3)

run(out rc ${CLI} train-residual --resume ${OUT}/comp/checkpoint.bin --iterations 4 --out ${OUT}/one)
message(STATUS "1 process on the 2-rank checkpoint: exit ${rc}\n${out}")
expect_refusal("${rc}" "${out}" "written by a run of 2 rank\\(s\\), this run has 1" "the 2-rank checkpoint in one process")

run(out rc ${MPIEXEC} ${FLAGS} -np 2 ${CLI} train-residual --task location --base ${BASE} --iterations 1 ${tiny} --out ${OUT}/loc)
message(STATUS "location, 2 ranks: exit ${rc}\n${out}")
if(NOT rc EQUAL 0 OR NOT out MATCHES "last location reward")
  message(FATAL_ERROR "mpirun -np 2 train-residual --task location failed")
endif()
file(STRINGS ${OUT}/loc/log.jsonl lines)
list(GET lines 0 first)
string(JSON r ERROR_VARIABLE e GET "${first}" location_reward)
if(e OR r STREQUAL "null")
  message(FATAL_ERROR "loc/log.jsonl has no location_reward: ${first}")
endif()

run(out rc ${MPIEXEC} ${FLAGS} -np 2 ${CLI} train-residual --task composition --base ${BASE} --new-motion kick
    --iterations 1 --config ${CONFIG} --threads 1 --envs 3 --out ${OUT}/odd)
message(STATUS "3 envs on 2 ranks: exit ${rc}\n${out}")
expect_refusal("${rc}" "${out}" "rank [01] of 2: error: .*3 envs do not split evenly over 2 ranks" "3 envs on 2 ranks")

run(out rc ${MPIEXEC} ${FLAGS} -np 2 ${CLI} eval-residual ${OUT}/comp/checkpoint.bin)
message(STATUS "eval-residual on 2 ranks: exit ${rc}\n${out}")
expect_refusal("${rc}" "${out}" "only `train-base` and `train-residual` run distributed" "eval-residual under mpirun")
