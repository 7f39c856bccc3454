// SPDX-License-Identifier: Apache-2.0
// WiFiUdpPublisher: an ESP32 on a skrobot hub over WiFi, in UDP datagrams
// (docs/microcontrollers.md, "UDP over WiFi"). On the hub: server.udp in its config, and the board's key:
//   skrobot user key robot        -> 32 hex digits, put them in BOARD_KEY below
// - publishes analogRead(ADC_PIN) at 10 Hz on <user>.analog (2 bytes, little-endian);
// - subscribes to SETPOINT_CHANNEL: its first byte goes to the PWM pin;
// - answers the service <user>.board: set_pwm (an integer 0..255), read_adc.
// Any of Arduino's UDP classes works the same: for an Ethernet shield, include <Ethernet.h> and
// <EthernetUdp.h>, declare `EthernetUDP udp;` and call Ethernet.begin() in joinNetwork().
#include <SkRobotFlowUdp.h>
#include <WiFi.h>
#include <WiFiUdp.h>

#ifndef WIFI_SSID
#define WIFI_SSID "my-network"
#endif
#ifndef WIFI_PASSWORD
#define WIFI_PASSWORD "my-password"
#endif
#ifndef HUB_IP
#define HUB_IP 192, 168, 1, 10  // server.udp's address
#endif
#ifndef HUB_PORT
#define HUB_PORT 9001  // server.udp's port
#endif
#ifndef BOARD_USER
#define BOARD_USER "robot"  // the account whose key this is
#endif
#ifndef BOARD_KEY
#define BOARD_KEY "00000000000000000000000000000000"  // from `skrobot user key robot`
#endif
#ifndef SETPOINT_CHANNEL
#define SETPOINT_CHANNEL "guest.setpoint"
#endif
#ifndef ADC_PIN
#define ADC_PIN A0
#endif
#ifndef PWM_PIN
#define PWM_PIN 5
#endif

const unsigned long kPeriodMs = 100;  // 10 Hz

WiFiUDP udp;
SkRobotFlowUdp flow(udp, IPAddress(HUB_IP), HUB_PORT);
int analog = -1;
unsigned long next_ms = 0;

void setPwm(int64_t v) { analogWrite(PWM_PIN, v < 0 ? 0 : v > 255 ? 255 : (int)v); }

void onSetpoint(void*, const uint8_t* payload, size_t n) {
  if (n > 0) setPwm(payload[0]);
}

void onBoard(void*, const char* cmd, size_t cmd_n, const uint8_t* value, size_t value_n,
             skr_out* answer) {
  int64_t v = 0;
  if (cmd_n == 7 && memcmp(cmd, "set_pwm", 7) == 0 && skr_value_int64(value, value_n, &v)) {
    setPwm(v);
    skr_put_int64(answer, v);
  } else if (cmd_n == 8 && memcmp(cmd, "read_adc", 8) == 0) {
    skr_put_int64(answer, analogRead(ADC_PIN));
  } else {
    skr_put_string(answer, "unknown command", 15);
  }
}

void joinNetwork() {
  WiFi.begin(WIFI_SSID, WIFI_PASSWORD);
  while (WiFi.status() != WL_CONNECTED) delay(100);
}

void setup() {
  pinMode(PWM_PIN, OUTPUT);
  joinNetwork();
  flow.begin(BOARD_USER, BOARD_KEY, "WiFiUdpPublisher");  // the handshake starts in poll()
  analog = flow.channel("analog", "application/x-u16le");
  flow.service("board", onBoard);
  flow.subscribe(SETPOINT_CHANNEL, onSetpoint);
}

void loop() {
  flow.poll();
  const unsigned long now = millis();
  if ((long)(now - next_ms) >= 0) {
    next_ms = now + kPeriodMs;
    const uint16_t v = analogRead(ADC_PIN);
    const uint8_t bytes[2] = {(uint8_t)(v & 0xFF), (uint8_t)(v >> 8)};
    flow.publish(analog, bytes, sizeof bytes);  // SKR_OFFLINE until connected: dropped
  }
}
