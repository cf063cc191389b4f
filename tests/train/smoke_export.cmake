# cmake -DCLI=… -DCKPT=… -DCONFIG=…/configs/smoke.json -DOUT=… -P smoke_export.cmake
# `maskadapt export` on the smoke training's checkpoint: the model file exists, is smaller, and
# play / eval-base / train-residual --base run on it; bad inputs (missing file, not a checkpoint,
# an export (of either stage), --out in a missing directory or over the input) fail with a
# maskadapt error that names the problem, never a crash.
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})
if(NOT EXISTS ${CKPT})
  message(FATAL_ERROR "missing ${CKPT}: run the train_base_cli_smoke test first")
endif()
set(MODEL ${OUT}/policy.bin)
execute_process(COMMAND ${CLI} export ${CKPT} --out ${MODEL} --note "smoke test"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "export failed (${rc})")
endif()
file(SIZE ${CKPT} ckpt_size)
file(SIZE ${MODEL} model_size)
math(EXPR limit "${ckpt_size} / 10")
if(NOT model_size LESS limit)
  message(FATAL_ERROR "export is ${model_size} bytes, the checkpoint ${ckpt_size}: expected under a tenth")
endif()
foreach(want "policy only" "iteration 3" "note: smoke test" "by commit ")
  string(FIND "${out}" "${want}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "export output lacks '${want}'")
  endif()
endforeach()

# play / eval-base take the export as they take the checkpoint
execute_process(COMMAND ${CLI} play ${MODEL} --mask left_leg --seconds 1 --deterministic --bvh ${OUT}/play.bvh
                --rollout ${OUT}/play.json RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "play on the export failed (${rc}): ${out}${err}")
endif()
string(FIND "${out}" "policy only" at)
if(at EQUAL -1 OR NOT EXISTS ${OUT}/play.bvh OR NOT EXISTS ${OUT}/play.json)
  message(FATAL_ERROR "play on the export: missing outputs or the 'policy only' note: ${out}")
endif()
execute_process(COMMAND ${CLI} eval-base ${MODEL} --envs 2 --frames 10 --threads 1 --json ${OUT}/hnorm.json
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS ${OUT}/hnorm.json)
  message(FATAL_ERROR "eval-base on the export failed (${rc}): ${out}${err}")
endif()
file(READ ${OUT}/hnorm.json h)
string(JSON nmasks LENGTH "${h}" masks)
if(NOT nmasks EQUAL 16)
  message(FATAL_ERROR "hnorm.json of the export: ${nmasks} masks, expected 16")
endif()

# and train-residual --base (stage 2 reads the actor sections only); its checkpoint is used below
execute_process(COMMAND ${CLI} train-residual --task composition --method ours --base ${MODEL} --new-motion kick
                --masks lower_body --switch-rate 1 --iterations 1 --config ${CONFIG} --threads 1 --envs 2 --hidden 16
                --episode-seconds 1 --out ${OUT}/residual RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS ${OUT}/residual/checkpoint.bin)
  message(FATAL_ERROR "train-residual --base on the export failed (${rc}): ${out}${err}")
endif()

# a stage-2 checkpoint exports too (its own smoke test plays and evaluates such exports)
execute_process(COMMAND ${CLI} export ${OUT}/residual/checkpoint.bin --out ${OUT}/residual_model.bin
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT "${out}" MATCHES "task composition, method ours")
  message(FATAL_ERROR "export of the stage-2 checkpoint failed (${rc}): ${out}${err}")
endif()

include(${CMAKE_CURRENT_LIST_DIR}/../cli_smoke_lib.cmake)
file(WRITE ${OUT}/notes.txt "not a checkpoint\n")
refused("a missing file" "missing\\.bin" export ${OUT}/missing.bin --out ${OUT}/x.bin)
refused("a text file" "notes\\.txt: not a maskadapt checkpoint" export ${OUT}/notes.txt --out ${OUT}/x.bin)
refused("a stage-2 export" "field 'model/kind': already a policy-only model file"
        export ${OUT}/residual_model.bin --out ${OUT}/x.bin)
refused("an export" "field 'model/kind': already a policy-only model file" export ${MODEL} --out ${OUT}/x.bin)
refused("into a missing directory" "field '--out': directory .*no/such/dir.* does not exist"
        export ${CKPT} --out ${OUT}/no/such/dir/x.bin)
refused("over its input" "field '--out': is the input checkpoint" export ${MODEL} --out ${MODEL})
if(EXISTS ${OUT}/x.bin)
  message(FATAL_ERROR "a refused export left ${OUT}/x.bin behind")
endif()
message(STATUS "export smoke OK: ${ckpt_size} -> ${model_size} bytes; play, eval-base and train-residual ran on the export")
