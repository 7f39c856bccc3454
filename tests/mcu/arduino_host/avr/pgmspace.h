// SPDX-License-Identifier: Apache-2.0
// avr/pgmspace.h for the host (arduino_udp_test): program memory is memory.
#ifndef SKR_HOST_PGMSPACE_H
#define SKR_HOST_PGMSPACE_H

#include <string.h>

#define PROGMEM
#define PGM_P const char*
#define PSTR(s) (s)
#define pgm_read_byte(p) (*(const unsigned char*)(p))
#define pgm_read_word(p) (*(const unsigned short*)(p))
#define strlen_P strlen
#define strcpy_P strcpy
#define strncpy_P strncpy
#define strcmp_P strcmp
#define strncmp_P strncmp
#define strcat_P strcat
#define strstr_P strstr
#define memcpy_P memcpy

/* avr-libc's stdlib.h has these and the core's WString.cpp includes nothing else that would
 * declare them on the host: declared here (arduino_host.cpp defines them). */
#ifdef __cplusplus
extern "C" {
#endif
char* itoa(int value, char* s, int radix);
char* utoa(unsigned value, char* s, int radix);
char* ltoa(long value, char* s, int radix);
char* ultoa(unsigned long value, char* s, int radix);
char* dtostrf(double value, signed char width, unsigned char precision, char* s);
#ifdef __cplusplus
}
#endif

#endif
