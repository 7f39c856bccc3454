// SPDX-License-Identifier: Apache-2.0
// WiFiUDP for the host (arduino_udp_test): Arduino's UDP (the Debian core's Udp.h) on a POSIX
// socket bound to 127.0.0.1 on a port of the system's choosing. A sketch names its hub at a fixed
// port; a test's hub listens on another: `WiFiUDP::route(sketch_port, real_port)` maps the one to
// the other both ways, as a NAT on the path would.
#ifndef SKR_HOST_WIFI_UDP_H
#define SKR_HOST_WIFI_UDP_H

#include <Udp.h>

class WiFiUDP : public UDP {
 public:
  static void route(uint16_t sketch_port, uint16_t real_port);

  uint8_t begin(uint16_t port) override;
  void stop() override;
  int beginPacket(IPAddress ip, uint16_t port) override;
  int beginPacket(const char* host, uint16_t port) override;
  int endPacket() override;
  size_t write(uint8_t b) override;
  size_t write(const uint8_t* buffer, size_t size) override;
  int parsePacket() override;
  int available() override;
  int read() override;
  int read(unsigned char* buffer, size_t len) override;
  int read(char* buffer, size_t len) override { return read((unsigned char*)buffer, len); }
  int peek() override;
  void flush() override { in_len_ = in_at_ = 0; }
  IPAddress remoteIP() override { return remote_ip_; }
  uint16_t remotePort() override { return remote_port_; }

 private:
  int fd_ = -1;
  uint8_t out_[2048], in_[2048];
  size_t out_len_ = 0, in_len_ = 0, in_at_ = 0;
  IPAddress out_ip_, remote_ip_;
  uint16_t out_port_ = 0, remote_port_ = 0;
};

#endif
