# Offline determinism of TAA (issue 14 item 4): `penumbra render --frames N --fixed-dt T --taa on`
# renders frame k at time k * T with jitter phase k (the renderer's frame index, not wall time), so
# two runs write byte-identical PNGs; a run with --taa off must differ (the flag took effect).
#   cmake -DCLI=<penumbra> -DSCENE=<scene> -DOUT=<dir> -DBACKEND=<vulkan|gl> -P check_render_deterministic.cmake
foreach(var CLI SCENE OUT BACKEND)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_render_deterministic.cmake: -D${var}=... is required")
  endif()
endforeach()
file(MAKE_DIRECTORY ${OUT})
foreach(run a b off)
  set(taa on)
  if(run STREQUAL "off")
    set(taa off)
  endif()
  file(REMOVE ${OUT}/${run}.png)
  execute_process(
    COMMAND ${CLI} render ${SCENE} --backend ${BACKEND} --width 96 --height 54 --no-cache --frames 6
            --fixed-dt 0.25 --taa ${taa} -o ${OUT}/${run}.png
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "penumbra render (${run}) failed (${rc}):\n${out}\n${err}")
  endif()
  file(SHA256 ${OUT}/${run}.png hash_${run})
endforeach()
if(NOT hash_a STREQUAL hash_b)
  message(FATAL_ERROR "two runs of --frames 6 --fixed-dt 0.25 --taa on differ: ${hash_a} vs ${hash_b}")
endif()
if(hash_a STREQUAL hash_off)
  message(FATAL_ERROR "--taa on and --taa off wrote the same image: the flag had no effect")
endif()
message("--taa on twice: identical (${hash_a}); --taa off differs")
