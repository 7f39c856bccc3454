// SPDX-License-Identifier: Apache-2.0
// The board library for Arduino: a skrobot session (skr_flow.h) over any Stream (Serial, Serial1,
// SoftwareSerial; over UDP, WiFiUDP or EthernetUDP: SkRobotFlowUdp.h). Declare it once, globally,
// and call poll() from loop():
//
//   SkRobotFlow flow(Serial);
//   void setup() { Serial.begin(115200); flow.begin("robot", "secret", "uno"); ... }
//   void loop() { flow.poll(); ... }
//
// Callbacks run inside poll(). Settings (SKR_RX_MAX, SKR_MAX_CHANNELS ...) are in skr_flow.h.
#ifndef SKROBOT_FLOW_ARDUINO_H
#define SKROBOT_FLOW_ARDUINO_H

#include <Arduino.h>

#include "SkRobotFlowBase.h"

// Bytes kept aside while a write waits for room: the stream's receive buffer (64 bytes on an Uno)
// would otherwise overflow while a frame goes out and the hub's answers come in.
#ifndef SKR_STASH
#define SKR_STASH 64
#endif

class SkRobotFlow : public SkRobotFlowBase {
 public:
  explicit SkRobotFlow(Stream& stream) : stream_(stream) {}

  // Strings are kept, not copied: pass literals. Logging in starts at the first poll().
  void begin(const char* user, const char* password, const char* client_name);
  // channel(), service(), subscribe(), follow(), publish(), setVar() ...: SkRobotFlowBase.h.

  void poll() { skr_poll(&flow_); }

 private:
  static int read(void* ctx);
  static void write(void* ctx, const uint8_t* data, size_t n);
  static uint32_t clock(void* ctx);

  // Moves what has arrived into the stash (while a write waits).
  void drain();

  Stream& stream_;
  uint8_t stash_[SKR_STASH];
  uint8_t stash_head_ = 0;
  uint8_t stash_count_ = 0;
};

#endif  // SKROBOT_FLOW_ARDUINO_H
