// SPDX-License-Identifier: Apache-2.0
// The board of bench/serial_udp: publishes on <user>.bench as fast as the line takes it, payloads
// of the size its service <user>.control last set (0: stops); echoes every payload of
// guest.ping on <user>.pong at once (latency).
#include <SkRobotFlow.h>

#ifndef SERIAL_BAUD
#define SERIAL_BAUD 115200
#endif

SkRobotFlow flow(Serial);
int bench = -1;
int pong = -1;
uint8_t size = 0;
uint8_t payload[128];
uint32_t seq = 0;

void onPing(void*, const uint8_t* p, size_t n) { flow.publish(pong, p, n); }

void onControl(void*, const char*, size_t, const uint8_t* value, size_t value_n, skr_out* answer) {
  int64_t s = 0;
  if (skr_value_int64(value, value_n, &s) && s >= 0 && s <= (int64_t)sizeof payload) {
    size = (uint8_t)s;
    skr_put_int64(answer, s);
  } else {
    skr_put_string(answer, "size 0..128", 11);
  }
}

void setup() {
  Serial.begin(SERIAL_BAUD);
  flow.begin("robot", "", "bench");
  bench = flow.channel("bench", "application/octet-stream");
  pong = flow.channel("pong", "application/octet-stream");
  flow.service("control", onControl);
  flow.subscribe("guest.ping", onPing);
}

void loop() {
  flow.poll();
  if (size >= 4 && flow.ready(bench)) {
    memcpy(payload, &seq, 4);
    if (flow.publish(bench, payload, size) == SKR_OK) ++seq;
  }
}
