# `cmake --install` layout and the exported package for find_package(penumbra):
#   <prefix>/include/penumbra/{engine,renderer,rhi}/...   headers (include as "engine/engine.h", "rhi/device.h")
#   <prefix>/lib/libpenumbra_*.a                          static libraries
#   <prefix>/lib/cmake/penumbra/                          penumbraConfig.cmake, version file, targets
#   <prefix>/bin/penumbra                                 the CLI
# Imported targets: penumbra::engine, penumbra::renderer (the embedding API: penumbra::Engine,
# penumbra::Renderer), penumbra::rhi, penumbra::plugin_api (headers for shared-library plugins).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(PENUMBRA_INSTALL_INCLUDEDIR ${CMAKE_INSTALL_INCLUDEDIR}/penumbra)
set(PENUMBRA_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/penumbra)

target_include_directories(penumbra_engine PUBLIC $<INSTALL_INTERFACE:${PENUMBRA_INSTALL_INCLUDEDIR}>)
target_include_directories(penumbra_renderer PUBLIC $<INSTALL_INTERFACE:${PENUMBRA_INSTALL_INCLUDEDIR}>)
target_include_directories(penumbra_rhi PUBLIC $<INSTALL_INTERFACE:${PENUMBRA_INSTALL_INCLUDEDIR}>)
target_include_directories(penumbra_plugin_api INTERFACE $<INSTALL_INTERFACE:${PENUMBRA_INSTALL_INCLUDEDIR}>)

set_target_properties(penumbra_engine PROPERTIES EXPORT_NAME engine)
set_target_properties(penumbra_renderer PROPERTIES EXPORT_NAME renderer)
set_target_properties(penumbra_rhi PROPERTIES EXPORT_NAME rhi)
set_target_properties(penumbra_stb PROPERTIES EXPORT_NAME stb)
set_target_properties(penumbra_plugin_api PROPERTIES EXPORT_NAME plugin_api)

install(TARGETS penumbra_engine penumbra_renderer penumbra_rhi penumbra_stb penumbra_plugin_api
        EXPORT penumbraTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${PENUMBRA_INSTALL_INCLUDEDIR})
install(TARGETS penumbra RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

foreach(dir engine renderer)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/ DESTINATION ${PENUMBRA_INSTALL_INCLUDEDIR}/${dir}
          FILES_MATCHING PATTERN "*.h" PATTERN "shaders" EXCLUDE)
endforeach()
# The RHI's method lists (device_api.inc, command_list_api.inc) are part of its public headers.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/rhi/include/rhi/ DESTINATION ${PENUMBRA_INSTALL_INCLUDEDIR}/rhi
        FILES_MATCHING PATTERN "*.h" PATTERN "*.inc")

install(EXPORT penumbraTargets NAMESPACE penumbra:: DESTINATION ${PENUMBRA_INSTALL_CMAKEDIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/penumbraConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/penumbraConfig.cmake
                              INSTALL_DESTINATION ${PENUMBRA_INSTALL_CMAKEDIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/penumbraConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/penumbraConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/penumbraConfigVersion.cmake
        DESTINATION ${PENUMBRA_INSTALL_CMAKEDIR})

# A sanitizer build installs instrumented libraries: their consumers must link the sanitizer
# runtimes too.
if(PENUMBRA_SANITIZE)
  target_link_options(penumbra_engine INTERFACE $<INSTALL_INTERFACE:-fsanitize=address,undefined>)
endif()
