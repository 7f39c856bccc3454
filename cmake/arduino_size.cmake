# SPDX-License-Identifier: Apache-2.0
# cmake -DAVR_SIZE=avr-size -DELF=<sketch.elf> -DOUT=<sketch.size> -P arduino_size.cmake
# Writes "flash <bytes>" and "ram <bytes>" for the Uno from `avr-size -C` (Program: text + data,
# Data: data + bss), as the Arduino IDE reports a sketch's size.
execute_process(COMMAND ${AVR_SIZE} -C --mcu=atmega328p ${ELF} OUTPUT_VARIABLE text
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "avr-size failed on ${ELF}")
endif()
if(NOT text MATCHES "Program: +([0-9]+) bytes")
  message(FATAL_ERROR "avr-size: no Program line for ${ELF}:\n${text}")
endif()
set(flash ${CMAKE_MATCH_1})
if(NOT text MATCHES "Data: +([0-9]+) bytes")
  message(FATAL_ERROR "avr-size: no Data line for ${ELF}:\n${text}")
endif()
file(WRITE ${OUT} "flash ${flash}\nram ${CMAKE_MATCH_1}\n")
