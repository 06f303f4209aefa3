# Installs the build tree into a fresh prefix, builds examples/embed against the installed package
# with find_package(penumbra) in a separate CMake project, and runs it on both backends.
# Arguments: -DBUILD_DIR= -DSOURCE_DIR= -DWORK_DIR= -DGENERATOR= [-DSANITIZE=ON]
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)

function(run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("[${step}] ${out}${err}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${step} failed (exit ${rc})")
  endif()
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

run(install ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(f lib/cmake/penumbra/penumbraConfig.cmake include/penumbra/engine/engine.h
          include/penumbra/renderer/renderer.h include/penumbra/rhi/device.h bin/penumbra
          lib/penumbra/plugins/stl_importer.so)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "the install is missing ${f}")
  endif()
endforeach()
if(EXISTS ${prefix}/lib/penumbra/plugins/fixture_no_entry.so)
  message(FATAL_ERROR "the install contains the plugin test fixtures")
endif()
# Nothing from the source or build tree may leak into the package.
file(GLOB_RECURSE cmake_files ${prefix}/lib/cmake/penumbra/*.cmake)
foreach(f ${cmake_files})
  file(READ ${f} text)
  string(FIND "${text}" "${SOURCE_DIR}" in_source)
  string(FIND "${text}" "${BUILD_DIR}" in_build)
  if(NOT in_source EQUAL -1 OR NOT in_build EQUAL -1)
    message(FATAL_ERROR "${f} refers to the source or build tree")
  endif()
endforeach()

run(configure ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/embed -B ${WORK_DIR}/build -G ${GENERATOR}
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix})
run(build ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
if(SANITIZE)
  # The example has no no-op dlclose glue (third_party/sanitizers), so LeakSanitizer would report
  # Mesa's spurious driver "leak" at exit; the library's own leaks are checked by the ASan suites.
  set(ENV{ASAN_OPTIONS} "detect_leaks=0")
endif()
foreach(backend vulkan gl)
  run(run-${backend} ${WORK_DIR}/build/embed_example --backend ${backend} -o ${WORK_DIR}/embed_${backend}.png)
  string(FIND "${last_output}" "wrote" wrote)
  if(wrote EQUAL -1)
    message(FATAL_ERROR "embed_example on ${backend} did not write its image")
  endif()
endforeach()
