# stend_add_plugin(NAME SOURCES src... [LIBRARIES lib...])
#
# Out-of-tree counterpart of the in-tree function of the same name. Builds the MODULE library
# stend_NAME.so (no "lib" prefix, hidden visibility, C++20) against Stend::sdk and installs it.
#
#   NAME       the plugin's name; must equal the name in STEND_DEFINE_PLUGIN ([a-z0-9_]+)
#   SOURCES    the plugin's sources
#   LIBRARIES  extra libraries to link privately (e.g. Stend::core, a vendor driver)
#
# Where things go:
#   build:    ${CMAKE_LIBRARY_OUTPUT_DIRECTORY} if set, else the top of the build directory, so
#             `STEND_PLUGIN_PATH=<build dir> stend plugins` finds it without installing.
#   install:  ${STEND_PLUGIN_INSTALL_DIR} — a cache variable defaulting to ${STEND_PLUGIN_DIR},
#             the plugin directory of the Stend installation found, where `stend` looks by
#             default. Set it (e.g. -DSTEND_PLUGIN_INSTALL_DIR=$HOME/stend-plugins) when that
#             directory isn't writable, and add that directory to STEND_PLUGIN_PATH.
#
# The target is called stend_plugin_NAME.
include_guard(GLOBAL)

set(STEND_PLUGIN_INSTALL_DIR "${STEND_PLUGIN_DIR}" CACHE PATH
  "Where stend_add_plugin() installs plugins (default: the Stend installation's plugin dir)")

function(stend_add_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT name MATCHES "^[a-z0-9_]+$")
    message(FATAL_ERROR "stend_add_plugin: plugin name '${name}' may contain only lower-case "
      "letters, digits and '_' (it is what experiments write after `plugin:`)")
  endif()
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "stend_add_plugin(${name}): no SOURCES given")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "stend_add_plugin(${name}): unexpected arguments: ${ARG_UNPARSED_ARGUMENTS}")
  endif()

  set(target stend_plugin_${name})
  add_library(${target} MODULE ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE Stend::sdk ${ARG_LIBRARIES})
  target_compile_features(${target} PRIVATE cxx_std_20)
  set_target_properties(${target} PROPERTIES
    PREFIX ""
    SUFFIX ".so"
    OUTPUT_NAME stend_${name}
    CXX_EXTENSIONS OFF
    CXX_VISIBILITY_PRESET hidden
    C_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  if(NOT CMAKE_LIBRARY_OUTPUT_DIRECTORY)
    set_target_properties(${target} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR})
  endif()
  install(TARGETS ${target} LIBRARY DESTINATION "${STEND_PLUGIN_INSTALL_DIR}")
endfunction()
