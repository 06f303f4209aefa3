# CTest script (cmake -P): proves that penumbra_add_shader_dir wires shader errors into the build.
#   -DSHADERC=<penumbra-shaderc> -DSHADERS_CMAKE=<PenumbraShaders.cmake> -DFIXTURE=<build_project dir>
#   -DWORK=<scratch dir> -DGENERATOR=<CMake generator>
# 1. A folder with a syntax error: configure succeeds, the build fails and prints bad.comp:6:.
# 2. A good folder: builds; a second build does nothing; editing an #included file rebuilds the
#    program (the depfile is honoured); editing nothing again does nothing.
foreach(var SHADERC SHADERS_CMAKE FIXTURE WORK GENERATOR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "build_project_test.cmake: -D${var}=... is required")
  endif()
endforeach()

file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")

function(configure_fixture build_dir shader_dir)
  execute_process(
    COMMAND "${CMAKE_COMMAND}" -S "${FIXTURE}" -B "${build_dir}" -G "${GENERATOR}"
            "-DPENUMBRA_SHADERS_CMAKE=${SHADERS_CMAKE}" "-DPENUMBRA_SHADERC_EXECUTABLE=${SHADERC}"
            "-DSHADER_DIR=${shader_dir}"
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "configuring the fixture project failed (${rc}):\n${out}")
  endif()
endfunction()

# Writes an edit to a source file, a little over a second after the last build: the kernel stamps
# files from a coarse clock (a few milliseconds; a second on some filesystems), so an edit written
# in the tick in which the build wrote its outputs has their mtime and ninja, which rebuilds only
# for a newer input, would see nothing to do (seen under a parallel ctest run).
function(edit_source path content)
  execute_process(COMMAND "${CMAKE_COMMAND}" -E sleep 1.1)
  file(WRITE "${path}" "${content}")
endfunction()

function(build_fixture build_dir out_rc out_text)
  execute_process(COMMAND "${CMAKE_COMMAND}" --build "${build_dir}"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  set(${out_rc} "${rc}" PARENT_SCOPE)
  set(${out_text} "${out}" PARENT_SCOPE)
endfunction()

# --- 1. the build fails on a shader error, naming file and line ---------------------------------
configure_fixture("${WORK}/bad-build" "${FIXTURE}/bad")
build_fixture("${WORK}/bad-build" rc out)
if(rc EQUAL 0)
  message(FATAL_ERROR "the build with a broken shader succeeded:\n${out}")
endif()
if(NOT out MATCHES "bad\\.comp:6: error: ")
  message(FATAL_ERROR "the failed build does not name bad.comp:6:\n${out}")
endif()
message(STATUS "broken shader fails the build as expected")

# --- 2. good shaders build; includes are tracked ------------------------------------------------
file(COPY "${FIXTURE}/good/" DESTINATION "${WORK}/good-src")
configure_fixture("${WORK}/good-build" "${WORK}/good-src")
build_fixture("${WORK}/good-build" rc out)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the build with good shaders failed:\n${out}")
endif()
set(generated "${WORK}/good-build/generated_shaders/shaders/shaders/good.cpp")
if(NOT EXISTS "${generated}")
  message(FATAL_ERROR "expected generated file ${generated}")
endif()
set(marker "penumbra-shaderc: shader program good")
if(NOT out MATCHES "${marker}")
  message(FATAL_ERROR "first build did not run the shader compiler:\n${out}")
endif()

build_fixture("${WORK}/good-build" rc out)
if(NOT rc EQUAL 0 OR out MATCHES "${marker}")
  message(FATAL_ERROR "an up-to-date build ran the shader compiler again:\n${out}")
endif()

# Edit the included file (new content so the generated code changes too).
edit_source("${WORK}/good-src/common.glsl" "float commonValue() { return 2.0; }\n")
build_fixture("${WORK}/good-build" rc out)
if(NOT rc EQUAL 0 OR NOT out MATCHES "${marker}")
  message(FATAL_ERROR "editing an #included file did not rebuild the program:\n${out}")
endif()

# Break the included file: the build must fail and name the include with its line.
edit_source("${WORK}/good-src/common.glsl" "float commonValue() {\n    return missingThing;\n}\n")
build_fixture("${WORK}/good-build" rc out)
if(rc EQUAL 0 OR NOT out MATCHES "common\\.glsl:2: error: ")
  message(FATAL_ERROR "an error in an #included file did not fail the build with common.glsl:2:\n${out}")
endif()
message(STATUS "include edits are tracked and include errors fail the build")
