// SPDX-License-Identifier: Apache-2.0
// AnalogPublisher: an Arduino Uno on a skrobot hub over USB serial (docs/microcontrollers.md).
// - publishes analogRead(A0) at 50 Hz on <user>.analog (2 bytes, little-endian);
// - subscribes to SETPOINT_CHANNEL: its first byte goes to the PWM pin;
// - answers the service <user>.board: set_pwm (an integer 0..255), read_adc (an input 0..5),
//   steps (the sync pulses counted);
// - follows the sync source PULSE_CHANNEL and counts its steps.
#include <SkRobotFlow.h>

#ifndef SKR_USER
#define SKR_USER "robot"
#endif
#ifndef SKR_PASSWORD
#define SKR_PASSWORD ""  // a port bound to an account (server.serial) needs none
#endif
#ifndef SETPOINT_CHANNEL
#define SETPOINT_CHANNEL "guest.setpoint"
#endif
#ifndef PULSE_CHANNEL
#define PULSE_CHANNEL "guest.pulse"
#endif
#ifndef SERIAL_BAUD
#define SERIAL_BAUD 115200
#endif

const uint8_t kPwmPin = 9;
const unsigned long kPeriodMs = 20;  // 50 Hz

SkRobotFlow flow(Serial);
int analog = -1;
uint32_t steps = 0;
unsigned long next_ms = 0;
bool described = false;

void setPwm(int64_t v) { analogWrite(kPwmPin, v < 0 ? 0 : v > 255 ? 255 : (int)v); }

void onSetpoint(void*, const uint8_t* payload, size_t n) {
  if (n > 0) setPwm(payload[0]);
}

void onStep(void*, uint32_t, uint32_t) { ++steps; }

void onBoard(void*, const char* cmd, size_t cmd_n, const uint8_t* value, size_t value_n,
             skr_out* answer) {
  int64_t v = 0;
  const bool has = skr_value_int64(value, value_n, &v);
  if (cmd_n == 7 && memcmp(cmd, "set_pwm", 7) == 0 && has) {
    setPwm(v);
    skr_put_int64(answer, v);
  } else if (cmd_n == 8 && memcmp(cmd, "read_adc", 8) == 0) {
    skr_put_int64(answer, analogRead(A0 + (has && v >= 0 && v <= 5 ? (int)v : 0)));
  } else if (cmd_n == 5 && memcmp(cmd, "steps", 5) == 0) {
    skr_put_int64(answer, steps);
  } else {
    skr_put_string(answer, "unknown command", 15);
  }
}

void setup() {
  pinMode(kPwmPin, OUTPUT);
  Serial.begin(SERIAL_BAUD);
  flow.begin(SKR_USER, SKR_PASSWORD, "AnalogPublisher");
  analog = flow.channel("analog", "application/x-u16le");
  flow.service("board", onBoard);
  flow.subscribe(SETPOINT_CHANNEL, onSetpoint);
  flow.follow(PULSE_CHANNEL, onStep);
}

void loop() {
  flow.poll();
  if (!flow.connected()) {
    described = false;
  } else if (!described) {
    // What the channel carries, in the flow's database, as any satellite describes its channels.
    described = flow.setVar("analog.rate_hz", (int64_t)(1000 / kPeriodMs)) == SKR_OK &&
                flow.setVar("analog.format", "u16le") == SKR_OK;
  }
  const unsigned long now = millis();
  if ((long)(now - next_ms) >= 0) {
    next_ms = now + kPeriodMs;
    const uint16_t v = analogRead(A0);
    const uint8_t bytes[2] = {(uint8_t)(v & 0xFF), (uint8_t)(v >> 8)};
    flow.publish(analog, bytes, sizeof bytes);  // SKR_OFFLINE until connected: dropped
  }
}
