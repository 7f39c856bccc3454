# SPDX-License-Identifier: Apache-2.0
# The Debian packages skrobot and skrobot-dev, built by CPack from an installed tree:
#   tools/bootstrap.sh package      (or: cpack --config <build>/CPackConfig.cmake -B <dir>)
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME skrobot)
set(CPACK_PACKAGE_VENDOR "skrobot")
set(CPACK_PACKAGE_CONTACT "skrobot maintainers <skrobot@localhost>")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_GROUPING ONE_PER_GROUP)
set(CPACK_COMPONENTS_ALL runtime hub flowctl python system dev)
foreach(component runtime hub flowctl python system)
  string(TOUPPER ${component} c)
  set(CPACK_COMPONENT_${c}_GROUP skrobot)
endforeach()
set(CPACK_COMPONENT_DEV_GROUP dev)

set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_SKROBOT_PACKAGE_NAME skrobot)
set(CPACK_DEBIAN_SKROBOT_PACKAGE_DEPENDS "adduser, python3")
# The first line is the synopsis (CPACK_PACKAGE_DESCRIPTION_SUMMARY stays unset: CPack would
# prepend it); CPack indents the rest.
set(CPACK_DEBIAN_SKROBOT_DESCRIPTION
"plugin-based robotics hub
A hub process with an event loop and a FlowNetwork; modules are shared objects declared in a
JSON config; satellites in C++ or Python exchange data over streaming, service and blob
channels. Includes the modules, flowctl, the PySketch Python package, the avatar web page and
a systemd service (skrobot.service) running the hub as the system user skrobot.")
set(CPACK_DEBIAN_SKROBOT_PACKAGE_CONTROL_EXTRA
  ${CMAKE_CURRENT_SOURCE_DIR}/debian/conffiles ${CMAKE_CURRENT_SOURCE_DIR}/debian/postinst
  ${CMAKE_CURRENT_SOURCE_DIR}/debian/prerm ${CMAKE_CURRENT_SOURCE_DIR}/debian/postrm)
set(CPACK_DEBIAN_SKROBOT_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_DEV_PACKAGE_NAME skrobot-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
  "skrobot (= ${PROJECT_VERSION}), libuv1-dev, libjsoncpp-dev, pkg-config")
set(CPACK_DEBIAN_DEV_DESCRIPTION
"skrobot hub: module SDK and satellite development files
Headers, the runtime, module-support and satellite libraries for linking, the CMake packages
skrobot_module and skrobot_satellite, and the pkg-config files skrobot-module and
skrobot-satellite.")
# The hub's own libraries are in the same package (found through the binaries' RPATH).
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS
  ${CMAKE_BINARY_DIR}/lib)
include(CPack)
