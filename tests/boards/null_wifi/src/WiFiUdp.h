// SPDX-License-Identifier: Apache-2.0
// WiFiUDP of the null WiFi library (WiFi.h): a UDP class whose bytes go through one register.
#ifndef NULL_WIFI_UDP_H
#define NULL_WIFI_UDP_H

#include <Udp.h>

class WiFiUDP : public UDP {
 public:
  uint8_t begin(uint16_t) override;
  void stop() override {}
  int beginPacket(IPAddress, uint16_t) override { return 1; }
  int beginPacket(const char*, uint16_t) override { return 1; }
  int endPacket() override;
  size_t write(uint8_t b) override;
  size_t write(const uint8_t* buffer, size_t size) override;
  int parsePacket() override;
  int available() override;
  int read() override;
  int read(unsigned char* buffer, size_t len) override;
  int read(char* buffer, size_t len) override { return read((unsigned char*)buffer, len); }
  int peek() override { return -1; }
  void flush() override {}
  IPAddress remoteIP() override;
  uint16_t remotePort() override;
};

#endif
