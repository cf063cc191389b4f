# cmake -DCLI=… -DCKPT=… -DOUT=… -P smoke_play_eval.cmake
# play and eval-base on the smoke training's checkpoint; every output must exist and parse
# (here: BVH header and frame count, CSV rows, JSON documents parsed with string(JSON); the
# library's own BVH and rollout readers re-read play's outputs in test_mujoco_resume.cpp).
file(REMOVE_RECURSE ${OUT})
if(NOT EXISTS ${CKPT})
  message(FATAL_ERROR "missing ${CKPT}: run the train_base_cli_smoke test first")
endif()
execute_process(COMMAND ${CLI} play ${CKPT} --mask left_leg,right_leg --seconds 1 --bvh ${OUT}/legs.bvh
                        --csv ${OUT}/root_xy.csv --rollout ${OUT}/legs.json --seed 3
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "play failed (${rc})")
endif()
execute_process(COMMAND ${CLI} play ${CKPT} --mask-schedule "0:none,0.5:lower_body" --seconds 1 --deterministic
                        --rollout ${OUT}/schedule.json RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "play --mask-schedule failed (${rc})")
endif()
# BVH: hierarchy, 31 frames at 1/30 s
file(READ ${OUT}/legs.bvh bvh)
if(NOT bvh MATCHES "^HIERARCHY" OR NOT bvh MATCHES "Frames:[ \t]+31[\r\n]")
  message(FATAL_ERROR "legs.bvh is not a 31-frame BVH")
endif()
# CSV: header + 31 rows
file(STRINGS ${OUT}/root_xy.csv csv)
list(LENGTH csv n)
list(GET csv 0 header)
if(NOT header STREQUAL "t,x,y" OR NOT n EQUAL 32)
  message(FATAL_ERROR "root_xy.csv: header '${header}', ${n} lines (expected t,x,y and 32)")
endif()
# viewer rollouts: valid JSON with the masks we asked for
file(READ ${OUT}/legs.json j)
string(JSON fmt GET "${j}" format)
if(NOT fmt STREQUAL "maskadapt-rollout")
  message(FATAL_ERROR "legs.json: format '${fmt}'")
endif()
file(READ ${OUT}/schedule.json j)
string(JSON nframes GET "${j}" num_frames)
if(NOT nframes EQUAL 31)
  message(FATAL_ERROR "schedule.json: ${nframes} frames, expected 31")
endif()
execute_process(COMMAND ${CLI} eval-base ${CKPT} --envs 2 --frames 10 --threads 1 --json ${OUT}/hnorm.json
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "eval-base failed (${rc})")
endif()
file(READ ${OUT}/hnorm.json h)
string(JSON nmasks LENGTH "${h}" masks)
string(JSON rows LENGTH "${h}" table_rsi)
string(JSON h00 GET "${h}" table_rsi 0 0)
if(NOT nmasks EQUAL 16 OR NOT rows EQUAL 5)
  message(FATAL_ERROR "hnorm.json: ${nmasks} masks, ${rows} table rows (expected 16 and 5)")
endif()
# --per-class: one row per (mask, class of the clips' frames), two masks
execute_process(COMMAND ${CLI} eval-base ${CKPT} --envs 2 --frames 10 --threads 1 --masks none legs --per-class
                        --json ${OUT}/classes.json
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "eval-base --per-class failed (${rc})")
endif()
file(READ ${OUT}/classes.json c)
string(JSON nclass LENGTH "${c}" per_class)
string(JSON class0 GET "${c}" per_class 0 class)
string(JSON mask1 GET "${c}" per_class 1 mask)
math(EXPR odd "${nclass} % 2")
if(nclass LESS 2 OR NOT odd EQUAL 0 OR NOT mask1 STREQUAL "left_leg,right_leg")
  message(FATAL_ERROR "classes.json: ${nclass} per-class rows, second mask '${mask1}' (expected 2 masks per class, legs second)")
endif()
message(STATUS "play / eval-base smoke OK: BVH, CSV, 2 rollouts, H_norm table (trunk: ${h00}), ${nclass} per-class rows (first: ${class0})")
