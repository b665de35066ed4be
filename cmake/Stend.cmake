# Build helpers shared by every folder.

# stend_add_library(NAME [SHARED|INTERFACE] [SOURCES ...] [PUBLIC ...] [PRIVATE ...])
# One folder's library `stend_NAME` (alias Stend::NAME): static unless SHARED or INTERFACE (all code
# is position-independent, CMAKE_POSITION_INDEPENDENT_CODE); its headers in the folder's include/ (stend/NAME/... by convention); the
# project's warnings. PUBLIC/PRIVATE are the libraries it depends on — the library arrows of
# docs/architecture.md.
function(stend_add_library name)
  cmake_parse_arguments(ARG "SHARED;INTERFACE" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  set(target stend_${name})
  if(ARG_INTERFACE)
    add_library(${target} INTERFACE)
    target_include_directories(${target} INTERFACE
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
      $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_link_libraries(${target} INTERFACE ${ARG_PUBLIC})
  else()
    if(ARG_SHARED)
      add_library(${target} SHARED ${ARG_SOURCES})
    else()
      add_library(${target} STATIC ${ARG_SOURCES})
    endif()
    target_include_directories(${target} PUBLIC
      $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
      $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    target_link_libraries(${target} PUBLIC ${ARG_PUBLIC} PRIVATE stend_warnings ${ARG_PRIVATE})
  endif()
  add_library(Stend::${name} ALIAS ${target})
endfunction()

# stend_add_plugin(NAME [TEST] SOURCES ... [LIBRARIES ...])
# Builds a Stend plugin shared library `stend_NAME.so` into the plugin directory of the build
# tree (and installs it into the install tree's plugin directory, unless TEST: a plugin that only
# the tests load is never installed). In-tree plugins link the
# libraries they need (stend_sim, stend_devices, stend_core); out-of-tree plugins use the installed SDK's stend_add_plugin (same signature).
function(stend_add_plugin name)
  cmake_parse_arguments(ARG "TEST" "" "SOURCES;LIBRARIES" ${ARGN})
  set(target stend_plugin_${name})
  add_library(${target} MODULE ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE stend_sdk stend_warnings ${ARG_LIBRARIES})
  set_target_properties(${target} PROPERTIES
    PREFIX "" OUTPUT_NAME stend_${name}
    LIBRARY_OUTPUT_DIRECTORY ${STEND_BUILD_PLUGIN_DIR}
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  if(NOT ARG_TEST)
    install(TARGETS ${target} LIBRARY DESTINATION ${STEND_PLUGIN_INSTALL_DIR})
  endif()
endfunction()

# Adds every immediate subfolder of the current source dir that has a CMakeLists.txt.
macro(stend_add_plugin_folders)
  file(GLOB _stend_children LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} *)
  list(SORT _stend_children)
  foreach(_child IN LISTS _stend_children)
    if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${_child} AND EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${_child}/CMakeLists.txt)
      add_subdirectory(${_child})
    endif()
  endforeach()
endmacro()

# stend_add_gtest(NAME SOURCES ... [LIBRARIES ...]) — one GoogleTest executable registered with
# ctest, linked with the shared test support stend_testing (testing/: paths, the skip rule for
# absent shared data, temporary folders, running the stend program, in-process runs).
function(stend_add_gtest name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE stend_core stend_testing stend_warnings GTest::gtest GTest::gtest_main
    ${ARG_LIBRARIES})
  gtest_discover_tests(${name} TEST_PREFIX "${name}." DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT 600)
endfunction()

# stend_add_estimator(NAME LIBRARY lib) — lists the estimator of folder estimators/NAME in the
# built-in registry: its library defines stend::NAME::estimator_entry() (registry.hpp). The
# registry code is generated from these calls in estimators/CMakeLists.txt.
function(stend_add_estimator name)
  cmake_parse_arguments(ARG "" "LIBRARY" "" ${ARGN})
  set_property(GLOBAL APPEND PROPERTY STEND_ESTIMATORS ${name})
  set_property(GLOBAL APPEND PROPERTY STEND_ESTIMATOR_LIBRARIES ${ARG_LIBRARY})
endfunction()
