# penumbra_add_shader_dir(<target> <dir>)
#
# Every <dir>/X.comp becomes the compute program X; every <dir>/X.vert + <dir>/X.frag pair becomes the
# graphics program X (*.glsl files are #include-only). For each program, penumbra-shaderc generates
#   ${CMAKE_CURRENT_BINARY_DIR}/generated_shaders/<target>/shaders/X.h and X.cpp
# The .cpp is added to <target>; the target can `#include <shaders/X.h>`. `#include "f.glsl"` is
# resolved against the including file's directory, then <dir>, then the repository's renderer/shaders.
# A depfile records every included file, so editing an include rebuilds the programs that use it.
#
# Each generated header declares, besides the rhi::ShaderDesc functions, one function overload per
# variant (`#pragma penumbra_variants` in the sources), C++ structs for the parameter blocks and
# named slots; it includes <penumbra/shader_interface.h> (tools/shaderc/include) and glm, and the
# shared ${gen_root}/shaders/view.h with the struct of the per-view block of
# renderer/shaders/view.glsl, which every program's View block is checked against.
#
# The compiler is the `penumbra-shaderc` target of this build, or the executable named by
# PENUMBRA_SHADERC_EXECUTABLE (for projects that include this file without building the tool).
# A <dir> that does not exist (git keeps no empty folders) simply contributes no programs.
# <target> may also be a custom target: the generated files are then built as part of it.

get_filename_component(PENUMBRA_REPO_ROOT "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)
set(PENUMBRA_REPO_ROOT "${PENUMBRA_REPO_ROOT}" CACHE INTERNAL "penumbra repository root")
set(PENUMBRA_VIEW_GLSL "${PENUMBRA_REPO_ROOT}/renderer/shaders/view.glsl" CACHE INTERNAL
    "the shared per-view block every shader program is checked against")

function(penumbra_add_shader_dir target dir)
  if(NOT TARGET ${target})
    message(FATAL_ERROR "penumbra_add_shader_dir: '${target}' is not a target")
  endif()
  if(ARGC GREATER 2)
    message(FATAL_ERROR "penumbra_add_shader_dir: expected (<target> <dir>), got extra arguments: ${ARGN}")
  endif()
  get_filename_component(dir "${dir}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")

  if(PENUMBRA_SHADERC_EXECUTABLE)
    set(tool "${PENUMBRA_SHADERC_EXECUTABLE}")
    set(tool_dep "${PENUMBRA_SHADERC_EXECUTABLE}")
  elseif(TARGET penumbra-shaderc)
    set(tool "$<TARGET_FILE:penumbra-shaderc>")
    set(tool_dep penumbra-shaderc)
  else()
    message(FATAL_ERROR "penumbra_add_shader_dir: no penumbra-shaderc target and PENUMBRA_SHADERC_EXECUTABLE unset")
  endif()

  file(GLOB comps CONFIGURE_DEPENDS "${dir}/*.comp")
  file(GLOB verts CONFIGURE_DEPENDS "${dir}/*.vert")
  file(GLOB frags CONFIGURE_DEPENDS "${dir}/*.frag")
  list(SORT comps)
  list(SORT verts)

  set(gen_root "${CMAKE_CURRENT_BINARY_DIR}/generated_shaders/${target}")
  set(out_dir "${gen_root}/shaders")
  set(include_args -I "${dir}" -I "${PENUMBRA_REPO_ROOT}/renderer/shaders")
  set(view_args --view-glsl "${PENUMBRA_VIEW_GLSL}")

  # Programs: "name|kind|source1[|source2]"
  set(programs)
  foreach(f IN LISTS comps)
    get_filename_component(name "${f}" NAME_WE)
    list(APPEND programs "${name}|comp|${f}")
  endforeach()
  foreach(f IN LISTS verts)
    get_filename_component(name "${f}" NAME_WE)
    if(NOT EXISTS "${dir}/${name}.frag")
      message(FATAL_ERROR "penumbra_add_shader_dir: ${f} has no matching ${dir}/${name}.frag")
    endif()
    list(APPEND programs "${name}|graphics|${f}|${dir}/${name}.frag")
  endforeach()
  foreach(f IN LISTS frags)
    get_filename_component(name "${f}" NAME_WE)
    if(NOT EXISTS "${dir}/${name}.vert")
      message(FATAL_ERROR "penumbra_add_shader_dir: ${f} has no matching ${dir}/${name}.vert")
    endif()
  endforeach()

  get_property(seen TARGET ${target} PROPERTY PENUMBRA_SHADER_PROGRAMS)
  set(generated)
  foreach(p IN LISTS programs)
    string(REPLACE "|" ";" parts "${p}")
    list(GET parts 0 name)
    list(GET parts 1 kind)
    if(name STREQUAL "view")
      message(FATAL_ERROR "penumbra_add_shader_dir: the program name 'view' (in ${dir}) is reserved for the shared per-view header shaders/view.h")
    endif()
    if(name IN_LIST seen)
      message(FATAL_ERROR "penumbra_add_shader_dir: shader program '${name}' (in ${dir}) is already part of target ${target}")
    endif()
    list(APPEND seen ${name})
    if(kind STREQUAL "comp")
      list(GET parts 2 comp)
      set(stage_args --comp "${comp}")
      set(sources "${comp}")
    else()
      list(GET parts 2 vert)
      list(GET parts 3 frag)
      set(stage_args --vert "${vert}" --frag "${frag}")
      set(sources "${vert}" "${frag}")
    endif()
    set(header "${out_dir}/${name}.h")
    set(source "${out_dir}/${name}.cpp")
    set(depfile "${gen_root}/${name}.d")
    add_custom_command(
      OUTPUT "${header}" "${source}"
      COMMAND "${tool}" --name ${name} --out-dir "${out_dir}" ${stage_args} ${include_args} ${view_args}
              --depfile "${depfile}"
      DEPENDS ${sources} "${PENUMBRA_VIEW_GLSL}" ${tool_dep}
      DEPFILE "${depfile}"
      COMMENT "penumbra-shaderc: shader program ${name}"
      VERBATIM)
    list(APPEND generated "${source}")
  endforeach()
  set_property(TARGET ${target} PROPERTY PENUMBRA_SHADER_PROGRAMS ${seen})

  # The shared per-view header, once per target.
  get_property(has_view_header TARGET ${target} PROPERTY PENUMBRA_SHADER_VIEW_HEADER SET)
  if(generated AND NOT has_view_header)
    set(view_header "${out_dir}/view.h")
    add_custom_command(
      OUTPUT "${view_header}"
      COMMAND "${tool}" --view-header ${view_args} --out-dir "${out_dir}" --depfile "${gen_root}/view.d"
      DEPENDS "${PENUMBRA_VIEW_GLSL}" ${tool_dep}
      DEPFILE "${gen_root}/view.d"
      COMMENT "penumbra-shaderc: shared per-view header"
      VERBATIM)
    list(APPEND generated "${view_header}")
    set_property(TARGET ${target} PROPERTY PENUMBRA_SHADER_VIEW_HEADER ON)
  endif()

  if(generated)
    target_sources(${target} PRIVATE ${generated})
  endif()
  # A custom target (e.g. one that only checks that shaders compile) has no include directories.
  get_target_property(target_type ${target} TYPE)
  if(NOT target_type STREQUAL "UTILITY")
    target_include_directories(${target} PRIVATE "${gen_root}" "${PENUMBRA_REPO_ROOT}/rhi/include"
                                                 "${PENUMBRA_REPO_ROOT}/tools/shaderc/include")
    # The parameter structs use glm types (header-only).
    if(TARGET glm::glm)
      target_link_libraries(${target} PRIVATE glm::glm)
    endif()
  endif()
endfunction()
