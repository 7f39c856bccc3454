// SPDX-License-Identifier: Apache-2.0
// Arduino.h for the host (arduino_udp_test): what the Debian Arduino core's Print, Stream,
// IPAddress, WString and the board library's Arduino classes need, and a sketch's pins, on Linux.
// The core's own sources are compiled against it unchanged.
#ifndef SKR_ARDUINO_HOST_H
#define SKR_ARDUINO_HOST_H

#include <avr/pgmspace.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef uint8_t byte;
typedef bool boolean;

#define HIGH 0x1
#define LOW 0x0
#define INPUT 0x0
#define OUTPUT 0x1
#define A0 14
#define A1 15

extern "C" {
unsigned long millis(void);
unsigned long micros(void);
void delay(unsigned long ms);
void pinMode(uint8_t pin, uint8_t mode);
int analogRead(uint8_t pin);
void analogWrite(uint8_t pin, int value);
}
long random(long howbig);
long random(long howsmall, long howbig);
void randomSeed(unsigned long seed);

#include "Stream.h"
#include "WString.h"

// The host's pins, read by the test: analogRead(A0) counts up from 0; analogWrite's last values.
int skr_host_last_analog_write(uint8_t pin);

#endif
