# cmake -DCLI=… -DCONFIG=…/configs/smoke.json -DOUT=… -P smoke_g1_cli.cmake
# The G1-like robot end to end through the command line, tiny sizes (issue 18, part 5):
# train-base --character g1 on the built-in walk retargeted onto the robot, its resume, eval-base,
# play (BVH + viewer rollout with the robot's 30 links), export; train-residual on that base
# (composition with a new motion, heading from scratch), play-residual and eval-residual; and
# what must be refused: an unknown character, another --character on a resume or beside a base of
# another character, and tracking on the robot (its text generator is the humanoid's).
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})
include(${CMAKE_CURRENT_LIST_DIR}/../cli_smoke_lib.cmake)

# stage 1 on the robot
run("train-base --character g1" train-base --config ${CONFIG} --character g1 --motions walk --iterations 2 --envs 2
    --threads 1 --out ${OUT}/base)
if(NOT LAST_OUTPUT MATCHES "train-base: g1 \\(29 DoF\\)")
  message(FATAL_ERROR "train-base did not say it runs the 29-DoF robot:\n${LAST_OUTPUT}")
endif()
json_field(${OUT}/base/config.json character env character)
if(NOT character STREQUAL "g1")
  message(FATAL_ERROR "config.json records env.character '${character}', expected g1")
endif()
run("train-base --resume (g1)" train-base --resume ${OUT}/base/checkpoint.bin --out ${OUT}/base --iterations 3)
file(STRINGS ${OUT}/base/log.jsonl lines)
list(LENGTH lines n)
if(NOT n EQUAL 3)
  message(FATAL_ERROR "expected 3 log lines after 2 + 1 iterations on the robot, found ${n}")
endif()
set(BASE ${OUT}/base/checkpoint.bin)

run("eval-base (g1)" eval-base ${BASE} --envs 2 --frames 20 --threads 1 --json ${OUT}/eval.json)
json_field(${OUT}/eval.json character character)
if(NOT character STREQUAL "g1")
  message(FATAL_ERROR "eval-base JSON names character '${character}', expected g1")
endif()
run("play (g1)" play ${BASE} --seconds 1 --rollout ${OUT}/play.json --bvh ${OUT}/play.bvh --mask legs)
json_field(${OUT}/play.json bodies skeleton bodies)
string(JSON nb LENGTH "${bodies}")
if(NOT nb EQUAL 30)
  message(FATAL_ERROR "the robot's rollout has ${nb} bodies, expected its 30 links")
endif()
if(NOT EXISTS ${OUT}/play.bvh)
  message(FATAL_ERROR "play wrote no BVH of the robot")
endif()
run("export (g1)" export ${BASE} --out ${OUT}/model.bin)
run("eval-base (g1 model)" eval-base ${OUT}/model.bin --envs 2 --frames 10 --threads 1)

# stage 2 on the robot's base
set(tiny --config ${CONFIG} --threads 1 --envs 2 --hidden 16 --episode-seconds 1)
run("train-residual composition (g1)" train-residual --task composition --method ours --base ${BASE} --new-motion arms
    --masks arms --iterations 1 ${tiny} --out ${OUT}/comp)
if(NOT LAST_OUTPUT MATCHES "train-residual: g1, task composition")
  message(FATAL_ERROR "train-residual did not run on the robot:\n${LAST_OUTPUT}")
endif()
run("play-residual (g1)" play-residual ${OUT}/comp/checkpoint.bin --seconds 1 --rollout ${OUT}/comp_play.json)
json_field(${OUT}/comp_play.json bodies skeleton bodies)
string(JSON nb LENGTH "${bodies}")
if(NOT nb EQUAL 30)
  message(FATAL_ERROR "the robot's residual rollout has ${nb} bodies, expected 30")
endif()
run("eval-residual composition (g1)" eval-residual ${OUT}/comp/checkpoint.bin --envs 2 --frames 20 --out ${OUT}/comp_eval.json)
run("export (g1 stage 2)" export ${OUT}/comp/checkpoint.bin --out ${OUT}/comp_model.bin)
run("train-residual heading scratch (g1)" train-residual --task heading --method scratch --character g1 --iterations 1
    ${tiny} --out ${OUT}/heading)

# refusals
refused("unknown character" "--character" train-base --config ${CONFIG} --character robot --iterations 1 --out ${OUT}/bad)
refused("--character on a resume" "--character" train-base --resume ${BASE} --character humanoid --out ${OUT}/bad)
refused("a humanoid --character beside a g1 base" "--character" train-residual --task composition --base ${BASE}
        --character humanoid --new-motion arms --masks arms --iterations 1 ${tiny} --out ${OUT}/bad)
refused("tracking on the robot" "tracking runs on the humanoid only" train-residual --task tracking --base ${BASE}
        --generator ${OUT}/none.bin --iterations 1 ${tiny} --out ${OUT}/bad)
