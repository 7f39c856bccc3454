# SPDX-License-Identifier: Apache-2.0
# skrobot_add_module(<name> SOURCES src... [LIBS lib...] [OUTPUT_DIR dir] [NO_INSTALL])
#
# Builds one hub module: a shared object named <name>.so (no "lib" prefix) that exports only its
# entry symbol (skrobot_module_entry), links the plugin API headers and the module-support
# library, and refuses undefined symbols at link time. Unless NO_INSTALL is given, `cmake
# --install` puts it into SKROBOT_MODULE_INSTALL_DIR (relative to the install prefix): the
# directory an installed hub searches by default.
#
# Used by the hub's own plugins/ and, installed as part of the module SDK, by
# find_package(skrobot_module) in a module's own project (docs/plugins.md).
include_guard(GLOBAL)

if(NOT DEFINED SKROBOT_MODULE_INSTALL_COMPONENT)
  set(SKROBOT_MODULE_INSTALL_COMPONENT module)
endif()

function(skrobot_add_module name)
  cmake_parse_arguments(M "NO_INSTALL" "OUTPUT_DIR" "SOURCES;LIBS" ${ARGN})
  if(NOT M_SOURCES)
    message(FATAL_ERROR "skrobot_add_module(${name}): no SOURCES")
  endif()
  add_library(${name} MODULE ${M_SOURCES})
  set_target_properties(${name} PROPERTIES PREFIX "" OUTPUT_NAME ${name}
    CXX_VISIBILITY_PRESET hidden C_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  if(M_OUTPUT_DIR)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${M_OUTPUT_DIR})
  elseif(SKROBOT_MODULE_OUTPUT_DIR)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${SKROBOT_MODULE_OUTPUT_DIR})
  endif()
  target_compile_features(${name} PRIVATE cxx_std_20)
  target_link_libraries(${name} PRIVATE skrobot::plugin_api skrobot::module_support ${M_LIBS})
  target_link_options(${name} PRIVATE -Wl,--no-undefined)
  if(NOT M_NO_INSTALL)
    install(TARGETS ${name} LIBRARY DESTINATION ${SKROBOT_MODULE_INSTALL_DIR}
      COMPONENT ${SKROBOT_MODULE_INSTALL_COMPONENT})
    set_property(GLOBAL APPEND PROPERTY SKROBOT_INSTALLED_MODULES ${name})
  endif()
  set_property(GLOBAL APPEND PROPERTY SKROBOT_MODULES ${name})
endfunction()
