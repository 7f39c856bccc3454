# SPDX-License-Identifier: Apache-2.0
# Arduino sketches for the Uno (ATmega328P), built with Debian's avr-gcc against Debian's Arduino
# core (arduino-core-avr), as the Arduino IDE builds them: the flags of the core's boards.txt and
# platform.txt (LTO included), the core compiled once into a static library, the .ino compiled
# as C++ after `#include <Arduino.h>`. The host compiler stays the project's: every AVR step is a
# custom command. Included from tests/boards when the heavy tests are on.
#
#   skrobot_add_sketch(<name> INO <file.ino> [LIBRARIES <library folder>...] [DEFINES NAME=value...])
#
# builds <build>/boards/<name>/<name>.elf (with the other .c and .cpp files of the .ino's
# folder, as the IDE does) and <name>.size ("flash <bytes>" and "ram <bytes>", from avr-size -C).
# Target sketch_<name>; its properties ELF and SIZE_FILE hold the two paths.
# A library folder is an Arduino library (library.properties, src/): every .c and .cpp under its
# src/ is compiled, and each library's src/ is on the include path of the sketch and of the others.
#
# Every sketch joins the target board_size, which prints the sketches' flash and RAM beyond the
# sketch named `empty` (bench/board_size).
#
# Sets SKROBOT_ARDUINO_FOUND, and SKROBOT_ARDUINO_MISSING (what is missing) when it is not.
include_guard(GLOBAL)
# This file's folder: its helpers are found from here, also when another project includes it
# (tests/boards/arduino_zip_test.sh builds the zip's examples in a project of its own).
set(_skr_arduino_cmake_dir ${CMAKE_CURRENT_LIST_DIR})

set(SKROBOT_ARDUINO_AVR_DIR /usr/share/arduino/hardware/arduino/avr
    CACHE PATH "The Arduino AVR core (Debian's arduino-core-avr)")
find_program(SKROBOT_AVR_GCC avr-gcc)
find_program(SKROBOT_AVR_GXX avr-g++)
find_program(SKROBOT_AVR_GCC_AR avr-gcc-ar)
find_program(SKROBOT_AVR_SIZE avr-size)

set(SKROBOT_ARDUINO_FOUND TRUE)
set(SKROBOT_ARDUINO_MISSING "")
foreach(tool SKROBOT_AVR_GCC SKROBOT_AVR_GXX SKROBOT_AVR_GCC_AR SKROBOT_AVR_SIZE)
  if(NOT ${tool})
    set(SKROBOT_ARDUINO_FOUND FALSE)
    list(APPEND SKROBOT_ARDUINO_MISSING ${tool})
  endif()
endforeach()
if(NOT EXISTS ${SKROBOT_ARDUINO_AVR_DIR}/cores/arduino/Arduino.h)
  set(SKROBOT_ARDUINO_FOUND FALSE)
  list(APPEND SKROBOT_ARDUINO_MISSING ${SKROBOT_ARDUINO_AVR_DIR}/cores/arduino)
endif()
if(NOT SKROBOT_ARDUINO_FOUND)
  return()
endif()

# The Uno's build (boards.txt: uno.build.*; ARDUINO is the IDE version the core ships with).
# DECIMAL_DIG: Debian's avr-libc lacks it and the core's WString.cpp uses it (9 digits suit
# AVR's 32-bit double).
set(SKROBOT_ARDUINO_DIR ${CMAKE_BINARY_DIR}/boards)
set(_skr_avr_common -mmcu=atmega328p -DF_CPU=16000000L -DARDUINO=10807 -DARDUINO_AVR_UNO
    -DARDUINO_ARCH_AVR -DDECIMAL_DIG=9 -I${SKROBOT_ARDUINO_AVR_DIR}/cores/arduino
    -I${SKROBOT_ARDUINO_AVR_DIR}/variants/standard -g -Os -ffunction-sections -fdata-sections
    -flto)
# platform.txt: compiler.c.flags, compiler.cpp.flags, compiler.S.flags.
set(_skr_avr_c -std=gnu11 -fno-fat-lto-objects)
set(_skr_avr_cxx -std=gnu++11 -fpermissive -fno-exceptions -fno-threadsafe-statics
    -Wno-error=narrowing)
set(_skr_avr_asm -x assembler-with-cpp)

# One custom command per source: <obj_dir>/<obj_name>.o, with a depfile for the headers it
# includes. `extra` are further flags (warnings, include folders); the object's path goes to
# `out_var`.
function(_skrobot_avr_compile out_var src obj_dir obj_name extra)
  get_filename_component(ext ${src} LAST_EXT)
  set(obj ${obj_dir}/${obj_name}.o)
  if(ext STREQUAL ".c")
    set(cmd ${SKROBOT_AVR_GCC} ${_skr_avr_common} ${_skr_avr_c})
  elseif(ext STREQUAL ".S")
    set(cmd ${SKROBOT_AVR_GCC} ${_skr_avr_common} ${_skr_avr_asm})
  elseif(ext STREQUAL ".ino")
    # The IDE prepends #include <Arduino.h> to the sketch (it also writes prototypes for the
    # sketch's functions: ours declare a function before they use it).
    set(cmd ${SKROBOT_AVR_GXX} ${_skr_avr_common} ${_skr_avr_cxx} -x c++ -include Arduino.h)
  else()
    set(cmd ${SKROBOT_AVR_GXX} ${_skr_avr_common} ${_skr_avr_cxx})
  endif()
  file(RELATIVE_PATH rel ${CMAKE_BINARY_DIR} ${obj})
  add_custom_command(OUTPUT ${obj}
    COMMAND ${cmd} ${extra} -MMD -MF ${obj}.d -c ${src} -o ${obj}
    DEPENDS ${src} DEPFILE ${obj}.d
    COMMENT "AVR ${rel}" VERBATIM)
  set(${out_var} ${obj} PARENT_SCOPE)
endfunction()

# The core, once: <build>/boards/core/libarduino_core.a (warnings off, as the IDE builds it).
set(SKROBOT_ARDUINO_CORE ${SKROBOT_ARDUINO_DIR}/core/libarduino_core.a)
file(GLOB _skr_core_sources ${SKROBOT_ARDUINO_AVR_DIR}/cores/arduino/*.c
     ${SKROBOT_ARDUINO_AVR_DIR}/cores/arduino/*.cpp ${SKROBOT_ARDUINO_AVR_DIR}/cores/arduino/*.S)
set(_skr_core_objects "")
foreach(src ${_skr_core_sources})
  get_filename_component(file ${src} NAME)
  _skrobot_avr_compile(obj ${src} ${SKROBOT_ARDUINO_DIR}/core ${file} "-w")
  list(APPEND _skr_core_objects ${obj})
endforeach()
add_custom_command(OUTPUT ${SKROBOT_ARDUINO_CORE}
  COMMAND ${CMAKE_COMMAND} -E rm -f ${SKROBOT_ARDUINO_CORE}
  COMMAND ${SKROBOT_AVR_GCC_AR} rcs ${SKROBOT_ARDUINO_CORE} ${_skr_core_objects}
  DEPENDS ${_skr_core_objects}
  COMMENT "AVR the Arduino core for the Uno" VERBATIM)
add_custom_target(skrobot_arduino_core DEPENDS ${SKROBOT_ARDUINO_CORE})
add_custom_target(board_size
  COMMAND /usr/bin/python3 ${_skr_arduino_cmake_dir}/../bench/board_size ${SKROBOT_ARDUINO_DIR}
  VERBATIM)

function(skrobot_add_sketch name)
  cmake_parse_arguments(A "" "INO" "LIBRARIES;DEFINES" ${ARGN})
  if(NOT A_INO)
    message(FATAL_ERROR "skrobot_add_sketch(${name}): INO is required")
  endif()
  get_filename_component(ino ${A_INO} ABSOLUTE)
  set(dir ${SKROBOT_ARDUINO_DIR}/${name})
  # The sketch's folder: its other .c and .cpp files too, as the IDE compiles them.
  get_filename_component(ino_dir ${ino} DIRECTORY)
  set(includes -I${ino_dir})
  set(sources ${ino})
  set(obj_names ${name}.ino)
  file(GLOB sketch_sources CONFIGURE_DEPENDS ${ino_dir}/*.c ${ino_dir}/*.cpp)
  foreach(src ${sketch_sources})
    get_filename_component(file ${src} NAME)
    list(APPEND sources ${src})
    list(APPEND obj_names sketch/${file})
  endforeach()
  foreach(lib ${A_LIBRARIES})
    get_filename_component(lib ${lib} ABSOLUTE)
    get_filename_component(lib_name ${lib} NAME)
    list(APPEND includes -I${lib}/src)
    file(GLOB_RECURSE lib_sources CONFIGURE_DEPENDS ${lib}/src/*.c ${lib}/src/*.cpp)
    foreach(src ${lib_sources})
      # <library>/<path under src/>: two files of one name in different folders stay apart.
      file(RELATIVE_PATH rel ${lib}/src ${src})
      list(APPEND sources ${src})
      list(APPEND obj_names ${lib_name}/${rel})
    endforeach()
  endforeach()
  # DEFINES (NAME=value) reach the sketch and its libraries: a library's settings (SKR_RX_MAX...).
  set(defines "")
  foreach(d ${A_DEFINES})
    list(APPEND defines -D${d})
  endforeach()
  set(objects "")
  foreach(src obj_name IN ZIP_LISTS sources obj_names)
    _skrobot_avr_compile(obj ${src} ${dir}/obj ${obj_name} "-Wall;-Wextra;${includes};${defines}")
    list(APPEND objects ${obj})
  endforeach()
  set(elf ${dir}/${name}.elf)
  set(size ${dir}/${name}.size)
  # platform.txt: compiler.c.elf.flags and recipe.c.combine.pattern.
  add_custom_command(OUTPUT ${elf}
    COMMAND ${SKROBOT_AVR_GCC} -w -Os -g -flto -fuse-linker-plugin -Wl,--gc-sections
            -mmcu=atmega328p -o ${elf} ${objects} ${SKROBOT_ARDUINO_CORE} -lm
    DEPENDS ${objects} ${SKROBOT_ARDUINO_CORE}
    COMMENT "AVR link boards/${name}/${name}.elf" VERBATIM)
  add_custom_command(OUTPUT ${size}
    COMMAND ${CMAKE_COMMAND} -DAVR_SIZE=${SKROBOT_AVR_SIZE} -DELF=${elf} -DOUT=${size}
            -P ${_skr_arduino_cmake_dir}/arduino_size.cmake
    DEPENDS ${elf} ${_skr_arduino_cmake_dir}/arduino_size.cmake VERBATIM)
  add_custom_target(sketch_${name} ALL DEPENDS ${elf} ${size})
  set_target_properties(sketch_${name} PROPERTIES ELF ${elf} SIZE_FILE ${size})
  add_dependencies(board_size sketch_${name})
endfunction()
