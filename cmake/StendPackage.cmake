# What `cmake --install` puts under the prefix besides the program, libraries and plugins (those
# are installed by their folders), and the Debian package (`cpack -G DEB`). docs/install.md.
#
#   <prefix>/bin/stend
#   <prefix>/<libdir>/libstend_{core,recording,yaml}.so, <libdir>/stend/plugins/stend_*.so (no test plugin)
#   <prefix>/include/stend/…, <libdir>/cmake/Stend/ (the SDK: headers, CMake package)
#   <prefix>/share/stend/configs/…                    shipped experiments
#   <prefix>/share/stend/estimators/<name>/examples/… example models, at the paths the configs
#   <prefix>/share/stend/diagnosis/examples/…          and the README name them (relative to configs/)
#   <prefix>/share/stend/sdk/template_sensor/          the out-of-tree plugin template
#   <prefix>/share/doc/stend/…                         README, user docs, JSON schemas
#
# So `cd <prefix>/share/stend && stend run configs/paper_mpu6050_z.yaml -o /tmp/runs` works as from
# the source tree.

set(STEND_DATA_INSTALL_DIR ${CMAKE_INSTALL_DATADIR}/stend)
set(STEND_DOC_INSTALL_DIR ${CMAKE_INSTALL_DATADIR}/doc/stend)

install(DIRECTORY configs DESTINATION ${STEND_DATA_INSTALL_DIR}
  PATTERN "run.sh" PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
# Example model files of every estimator and of the diagnosis (the configs name them as ../estimators/…).
file(GLOB _stend_example_dirs LIST_DIRECTORIES true RELATIVE ${PROJECT_SOURCE_DIR}
  ${PROJECT_SOURCE_DIR}/estimators/*/examples ${PROJECT_SOURCE_DIR}/estimators/*/example
  ${PROJECT_SOURCE_DIR}/diagnosis/examples)
foreach(_dir IN LISTS _stend_example_dirs)
  get_filename_component(_parent ${_dir} DIRECTORY)
  install(DIRECTORY ${_dir} DESTINATION ${STEND_DATA_INSTALL_DIR}/${_parent} FILES_MATCHING PATTERN "*.yaml")
endforeach()
install(DIRECTORY sdk/template_sensor DESTINATION ${STEND_DATA_INSTALL_DIR}/sdk)
install(DIRECTORY docs/ DESTINATION ${STEND_DOC_INSTALL_DIR})
install(FILES README.md DESTINATION ${STEND_DOC_INSTALL_DIR})
install(FILES estimators/allan/README.md DESTINATION ${STEND_DOC_INSTALL_DIR}/estimators RENAME allan.md)
install(FILES estimators/batch_lsq/README.md DESTINATION ${STEND_DOC_INSTALL_DIR}/estimators RENAME batch_lsq.md)
install(FILES estimators/ceres_nonlinear/README.md DESTINATION ${STEND_DOC_INSTALL_DIR}/estimators
  RENAME ceres_nonlinear.md)
install(FILES estimators/temp_poly/README.md DESTINATION ${STEND_DOC_INSTALL_DIR}/estimators RENAME temp_poly.md)

# ---- Debian package: cpack -G DEB (in the build folder) ----------------------------------------
set(CPACK_PACKAGE_NAME stend)
set(CPACK_PACKAGE_VENDOR "Stend")
set(CPACK_PACKAGE_CONTACT "Stend maintainers <stend@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)  # no debug info in the package (docs/install.md: sizes)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://example.invalid/stend")
# The run-time libraries from the binaries themselves (dpkg-shlibdeps); the package's own
# libstend_core.so is found through the install tree's lib folder.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS OFF)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${CMAKE_BINARY_DIR}/lib)
# Libraries opened on demand (core/on_demand/: libpq, matio) are not in any binary's NEEDED, so
# dpkg-shlibdeps cannot see them: their packages are named here, found with dpkg-query.
get_property(on_demand_files GLOBAL PROPERTY STEND_ON_DEMAND_FILES)
set(on_demand_packages "")
foreach(file IN LISTS on_demand_files)
  execute_process(COMMAND dpkg-query -S "${file}" OUTPUT_VARIABLE owner RESULT_VARIABLE rc ERROR_QUIET)
  if(rc EQUAL 0 AND owner MATCHES "^([^:,]+)")
    list(APPEND on_demand_packages "${CMAKE_MATCH_1}")
  endif()
endforeach()
list(REMOVE_DUPLICATES on_demand_packages)
list(JOIN on_demand_packages ", " CPACK_DEBIAN_PACKAGE_DEPENDS)
# The SDK's headers include these (a plugin built against the installed Stend needs them).
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "libeigen3-dev, cmake, g++")
# The Python module (python/, /usr/lib/python3/dist-packages/stend) needs Debian's Python and NumPy.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "python3, python3-numpy")
set(CPACK_GENERATOR DEB)
include(CPack)
