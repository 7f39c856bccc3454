# SPDX-License-Identifier: Apache-2.0
# The board library as an Arduino library zip: one folder, SkRobotFlow/, to unzip into a
# sketchbook's libraries folder (docs/microcontrollers.md). The host build's files
# (CMakeLists.txt, posix/) stay out.
#
#   cmake -DSOURCE=<satellite/mcu> -DOUT=<folder> -P cmake/arduino_zip.cmake
#
# writes <folder>/SkRobotFlow-<version>.zip (the version from library.properties) and prints its
# path. Used by tools/bootstrap.sh package and tests/boards/arduino_zip_test.sh.
if(NOT SOURCE OR NOT OUT)
  message(FATAL_ERROR "arduino_zip.cmake: SOURCE and OUT are required")
endif()
file(STRINGS ${SOURCE}/library.properties version_line REGEX "^version=")
string(REGEX REPLACE "^version=" "" version "${version_line}")
if(NOT version MATCHES "^[0-9]+\\.[0-9]+\\.[0-9]+$")
  message(FATAL_ERROR "arduino_zip.cmake: ${SOURCE}/library.properties: no version=X.Y.Z")
endif()
set(stage ${OUT}/arduino-zip-stage)
file(REMOVE_RECURSE ${stage})
file(MAKE_DIRECTORY ${stage}/SkRobotFlow)
file(COPY ${SOURCE}/library.properties ${SOURCE}/README.md ${SOURCE}/src ${SOURCE}/examples
     DESTINATION ${stage}/SkRobotFlow)
set(zip ${OUT}/SkRobotFlow-${version}.zip)
file(REMOVE ${zip})
execute_process(COMMAND ${CMAKE_COMMAND} -E tar cf ${zip} --format=zip SkRobotFlow
                WORKING_DIRECTORY ${stage} RESULT_VARIABLE rc)
file(REMOVE_RECURSE ${stage})
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "arduino_zip.cmake: zip failed (${rc})")
endif()
message("${zip}")
