// SPDX-License-Identifier: Apache-2.0
#include "WiFi.h"
#include "WiFiUdp.h"

NullWiFi WiFi;

static volatile uint8_t wire;  // where every byte goes and comes from

uint8_t WiFiUDP::begin(uint16_t) {
  return 1;
}
int WiFiUDP::endPacket() {
  return wire;
}
size_t WiFiUDP::write(uint8_t b) {
  wire = b;
  return 1;
}
size_t WiFiUDP::write(const uint8_t* buffer, size_t size) {
  for (size_t i = 0; i < size; ++i) wire = buffer[i];
  return size;
}
int WiFiUDP::parsePacket() {
  return wire;
}
int WiFiUDP::available() {
  return wire;
}
int WiFiUDP::read() {
  return wire;
}
int WiFiUDP::read(unsigned char* buffer, size_t len) {
  for (size_t i = 0; i < len; ++i) buffer[i] = wire;
  return (int)len;
}
IPAddress WiFiUDP::remoteIP() {
  return IPAddress(wire, wire, wire, wire);
}
uint16_t WiFiUDP::remotePort() {
  return wire;
}
