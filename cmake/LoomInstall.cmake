# `cmake --install BUILD [--prefix P]`: headers, libraries, the `loom` CLI and a CMake package, so another
# project can `find_package(loom)` and link `loom::cloth` (and the other loom:: targets this build made).
#   P/include/loom/...                        public headers of every installed library
#   P/lib/libloom_*.a                         the libraries
#   P/lib/cmake/loom/loomConfig.cmake         + loomConfigVersion.cmake (SameMajorVersion), loomTargets.cmake
# Dependencies are found again by loomConfig.cmake with find_dependency (Eigen3, OpenMP; fcl/GMP/Qhull for
# loom::collision, nlohmann_json for loom::scene, assimp for loom::characters, Bullet for loom::bullet). Tested by tests/consumer (ctest: consumer_package).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# Installed targets and their exported names (loom::<name>). Only targets this configuration defines.
set(_loom_export_names cloth collision bullet bullet_double characters scene export)
set(_loom_installed loom_warnings)
set(LOOM_PACKAGE_COMPONENTS "")
foreach(_name IN LISTS _loom_export_names)
  if(TARGET loom_${_name})
    list(APPEND _loom_installed loom_${_name})
    list(APPEND LOOM_PACKAGE_COMPONENTS ${_name})
    set_target_properties(loom_${_name} PROPERTIES EXPORT_NAME ${_name})
  endif()
endforeach()
# Private link dependency of the static libraries (warning flags only); exported so the link-only
# reference resolves, it carries nothing a consumer compiles with.
set_target_properties(loom_warnings PROPERTIES EXPORT_NAME warnings)

install(TARGETS ${_loom_installed} EXPORT loomTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
if(TARGET loom)
  install(TARGETS loom RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()

# Public headers: every include/ folder of an installed library.
foreach(_dir cloth collision bullet_bridge characters scene export)
  if(IS_DIRECTORY ${PROJECT_SOURCE_DIR}/${_dir}/include)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/${_dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
            FILES_MATCHING PATTERN "*.h" PATTERN "*.hpp")
  endif()
endforeach()

# Which extra dependencies the exported targets carry (read by loomConfig.cmake.in).
set(LOOM_PACKAGE_NEEDS_FCL OFF)
set(LOOM_PACKAGE_NEEDS_GMP OFF)
if(TARGET loom_collision)
  get_target_property(_loom_collision_links loom_collision INTERFACE_LINK_LIBRARIES)
  if(_loom_collision_links MATCHES "(^|;)fcl(;|$)")
    set(LOOM_PACKAGE_NEEDS_FCL ON)
  endif()
  if(_loom_collision_links MATCHES "PkgConfig::LOOM_GMP")
    set(LOOM_PACKAGE_NEEDS_GMP ON)
  endif()
endif()

set(LOOM_PACKAGE_NEEDS_JSON OFF)
if(TARGET loom_scene)
  set(LOOM_PACKAGE_NEEDS_JSON ON)
endif()
set(LOOM_PACKAGE_NEEDS_BULLET OFF)
if(TARGET loom_bullet AND NOT LOOM_BULLET_DOUBLE)  # float Bullet, found again by FindBullet
  set(LOOM_PACKAGE_NEEDS_BULLET ON)
endif()
set(LOOM_PACKAGE_NEEDS_ASSIMP OFF)
if(TARGET loom_characters)  # loom::characters links assimp (Debian libassimp-dev)
  set(LOOM_PACKAGE_NEEDS_ASSIMP ON)
endif()

set(_loom_cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/loom)
install(EXPORT loomTargets NAMESPACE loom:: DESTINATION ${_loom_cmake_dir})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/loomConfig.cmake.in
  ${PROJECT_BINARY_DIR}/loomConfig.cmake INSTALL_DESTINATION ${_loom_cmake_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/loomConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/loomConfig.cmake ${PROJECT_BINARY_DIR}/loomConfigVersion.cmake
  DESTINATION ${_loom_cmake_dir})
