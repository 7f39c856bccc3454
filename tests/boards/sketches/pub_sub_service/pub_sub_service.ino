// SPDX-License-Identifier: Apache-2.0
// The size target of the board library (docs/microcontrollers.md, "Sizes on the Uno"): one
// publisher, one subscriber and one service, nothing else (bench/board_size measures it).
#include <SkRobotFlow.h>

SkRobotFlow flow(Serial);
int out = -1;
uint8_t last = 0;

void onIn(void*, const uint8_t* payload, size_t n) {
  if (n > 0) last = payload[0];
}

void onCommand(void*, const char*, size_t, const uint8_t*, size_t, skr_out* answer) {
  skr_put_int64(answer, last);
}

void setup() {
  Serial.begin(115200);
  flow.begin("robot", "", "size");
  out = flow.channel("out", "application/octet-stream");
  flow.subscribe("guest.in", onIn);
  flow.service("command", onCommand);
}

void loop() {
  flow.poll();
  flow.publish(out, &last, 1);
}
