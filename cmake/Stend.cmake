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

# Every test carries one label, and each label its own time-out [s] (written here once):
#   unit         no process, no server, no network: in-process code on fixed or simulated data,
#                each test ≤ 10 s on the 2-core CI machine — `ctest -L unit` is the first loop
#   integration  starts the stend program, a server (PostgreSQL, Slurm, HTTP), a browser, an emulated
#                device on a pty or loopback socket, the firmware under simavr, or a long simulated run
#   e2e          the program end to end: shipped configs, the README's commands, real data, install
#   perf         speed guards and benchmark smoke runs (bench/)
#   fuzz         the short deterministic replay of each fuzz target (fuzz/)
# `ctest -L LABEL` runs one kind; scripts/test.sh runs them all.
set(STEND_TEST_LABELS unit integration e2e perf fuzz)
set(STEND_TEST_TIMEOUT_unit 60)
set(STEND_TEST_TIMEOUT_integration 600)
set(STEND_TEST_TIMEOUT_e2e 900)
set(STEND_TEST_TIMEOUT_perf 600)
set(STEND_TEST_TIMEOUT_fuzz 120)
# Sanitized builds (STEND_SANITIZE) run 3–10× slower: their time-outs are five times longer.
if(STEND_SANITIZE)
  set(STEND_TEST_TIMEOUT_SCALE 5)
else()
  set(STEND_TEST_TIMEOUT_SCALE 1)
endif()

# The time-out of `label` into `out` [s].
function(stend_test_timeout label out)
  math(EXPR t "${STEND_TEST_TIMEOUT_${label}} * ${STEND_TEST_TIMEOUT_SCALE}")
  set(${out} ${t} PARENT_SCOPE)
endfunction()

# stend_label_test(TEST LABEL): the label and its time-out on a test added with add_test().
function(stend_label_test test label)
  if(NOT label IN_LIST STEND_TEST_LABELS)
    message(FATAL_ERROR "test ${test}: label '${label}' is not one of ${STEND_TEST_LABELS}")
  endif()
  stend_test_timeout(${label} timeout)
  set_tests_properties(${test} PROPERTIES LABELS ${label} TIMEOUT ${timeout})
endfunction()

# stend_add_gtest(NAME LABEL unit|integration|e2e|perf SOURCES ... [LIBRARIES ...]) — one
# GoogleTest executable registered with ctest, each of its tests labelled LABEL with that label's
# time-out, linked with the shared test support stend_testing (testing/: paths, the skip rule for
# absent shared data, temporary folders, running the stend program, in-process runs).
function(stend_add_gtest name)
  cmake_parse_arguments(ARG "" "LABEL" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT ARG_LABEL IN_LIST STEND_TEST_LABELS)
    message(FATAL_ERROR "stend_add_gtest(${name}): give LABEL, one of ${STEND_TEST_LABELS}")
  endif()
  stend_test_timeout(${ARG_LABEL} timeout)
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE stend_core stend_testing stend_warnings GTest::gtest GTest::gtest_main
    ${ARG_LIBRARIES})
  gtest_discover_tests(${name} TEST_PREFIX "${name}." DISCOVERY_TIMEOUT 60
    PROPERTIES LABELS ${ARG_LABEL} TIMEOUT ${timeout})
endfunction()

# stend_add_benchmark(NAME SOURCES ... [LIBRARIES ...]) — a Google Benchmark executable (with
# STEND_BUILD_BENCHMARKS; figures in docs/benchmarks.md) and, with the tests, its smoke run
# `perf.NAME` (label perf): every benchmark once (--benchmark_min_time=0), so that none stops
# building or running unnoticed.
function(stend_add_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE stend_warnings benchmark::benchmark ${ARG_LIBRARIES})
  if(STEND_BUILD_TESTS)
    add_test(NAME perf.${name} COMMAND ${name} --benchmark_min_time=0)
    stend_label_test(perf.${name} perf)
  endif()
endfunction()

# stend_add_estimator(NAME LIBRARY lib) — lists the estimator of folder estimators/NAME in the
# built-in registry: its library defines stend::NAME::estimator_entry() (registry.hpp). The
# registry code is generated from these calls in estimators/CMakeLists.txt.
function(stend_add_estimator name)
  cmake_parse_arguments(ARG "" "LIBRARY" "" ${ARGN})
  set_property(GLOBAL APPEND PROPERTY STEND_ESTIMATORS ${name})
  set_property(GLOBAL APPEND PROPERTY STEND_ESTIMATOR_LIBRARIES ${ARG_LIBRARY})
endfunction()

# stend_soname(VAR LIBRARY_FILE): the SONAME of a shared library (readelf -d), what dlopen is
# given for a library opened on demand (core/on_demand/); fails the configuration without one.
function(stend_soname var file)
  get_filename_component(real "${file}" REALPATH)
  execute_process(COMMAND ${CMAKE_READELF} -d "${real}" OUTPUT_VARIABLE dynamic RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0 OR NOT dynamic MATCHES "Library soname: \\[([^]]+)\\]")
    message(FATAL_ERROR "cannot read the SONAME of ${file} (readelf -d)")
  endif()
  set(${var} "${CMAKE_MATCH_1}" PARENT_SCOPE)
  set_property(GLOBAL APPEND PROPERTY STEND_ON_DEMAND_FILES "${real}")  # the .deb depends on it: StendPackage.cmake
endfunction()
