// SPDX-License-Identifier: Apache-2.0
// pub_sub_service over UDP (SkRobotFlowUdp): one publisher, one subscriber and one service, nothing
// else, through the null WiFi library's UDP class (bench/board_size: compare with null_wifi_udp,
// the UDP class alone).
#include <SkRobotFlowUdp.h>
#include <WiFiUdp.h>

WiFiUDP udp;
SkRobotFlowUdp flow(udp, IPAddress(192, 168, 1, 10), 9001);
int out = -1;
uint8_t last = 0;

void onIn(void*, const uint8_t* payload, size_t n) {
  if (n > 0) last = payload[0];
}

void onCommand(void*, const char*, size_t, const uint8_t*, size_t, skr_out* answer) {
  skr_put_int64(answer, last);
}

void setup() {
  flow.begin("robot", "000102030405060708090a0b0c0d0e0f", "size");
  out = flow.channel("out", "application/octet-stream");
  flow.subscribe("guest.in", onIn);
  flow.service("command", onCommand);
}

void loop() {
  flow.poll();
  flow.publish(out, &last, 1);
}
