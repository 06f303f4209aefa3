# Offline time of `penumbra render` (issue 8, item 1): renders SCENE for FRAMES frames of FIXED_DT
# seconds and checks the --stats JSON: simTime must equal SIM_TIME exactly ((FRAMES - 1) * FIXED_DT,
# frame 0 being at t = 0) and updateSteps must equal STEPS (the frames' update steps, none dropped).
# Before the fix `--frames 3 --fixed-dt 1` gave 0.533 s (the real-time cap of 16 steps per frame)
# and `--frames 11 --fixed-dt 0.1` gave 0.98333 s (1/60 s rounded to 16 666 667 ns).
#   cmake -DCLI=<penumbra> -DSCENE=<scene> -DOUT=<dir> -DFRAMES=<n> -DFIXED_DT=<s> -DSIM_TIME=<s>
#         -DSTEPS=<n> -P check_render_sim_time.cmake
foreach(var CLI SCENE OUT FRAMES FIXED_DT SIM_TIME STEPS)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_render_sim_time.cmake: -D${var}=... is required")
  endif()
endforeach()
file(MAKE_DIRECTORY ${OUT})
set(stats ${OUT}/stats.json)
file(REMOVE ${stats})
execute_process(
  COMMAND ${CLI} render ${SCENE} --width 32 --height 18 --no-cache --frames ${FRAMES} --fixed-dt ${FIXED_DT}
          --stats ${stats} -o ${OUT}/image.png
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "penumbra render failed (${rc}):\n${out}\n${err}")
endif()
file(READ ${stats} json)
string(JSON sim_time GET "${json}" simTime)
string(JSON steps GET "${json}" updateSteps)
# EQUAL compares the numbers as doubles: 1.0000000000000002 is not 1.
if(NOT sim_time EQUAL SIM_TIME)
  message(FATAL_ERROR "--frames ${FRAMES} --fixed-dt ${FIXED_DT}: simTime ${sim_time}, expected exactly ${SIM_TIME}")
endif()
if(NOT steps EQUAL STEPS)
  message(FATAL_ERROR "--frames ${FRAMES} --fixed-dt ${FIXED_DT}: updateSteps ${steps}, expected ${STEPS}")
endif()
message("--frames ${FRAMES} --fixed-dt ${FIXED_DT}: simTime ${sim_time}, ${steps} update steps")
