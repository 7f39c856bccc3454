// SPDX-License-Identifier: Apache-2.0
// The null WiFi library's UDP class alone, used as a library would use it (bench/board_size: the
// baseline of udp_pub_sub_service, so that its difference is the board library's).
#include <WiFiUdp.h>

WiFiUDP udp;
UDP& any = udp;
uint8_t buf[8];

void setup() { any.begin(4210); }

void loop() {
  const int n = any.parsePacket();
  if (n > 0 && any.remoteIP() == IPAddress(192, 168, 1, 10) && any.remotePort() == 9001) {
    any.read(buf, sizeof buf);
    any.beginPacket(IPAddress(192, 168, 1, 10), 9001);
    any.write(buf, sizeof buf);
    any.endPacket();
  }
}
