// SPDX-License-Identifier: Apache-2.0
// The board library for Arduino over UDP: a skrobot session (skr_flow.h) in datagrams
// (skr_udp_link.h) through any of Arduino's UDP classes (WiFiUDP on an ESP32 or a WiFi shield,
// EthernetUDP), with the board's key from `skrobot user key NAME` (docs/microcontrollers.md,
// "UDP over WiFi"). Declare it once, globally, and call poll() from loop():
//
//   WiFiUDP udp;
//   SkRobotFlowUdp flow(udp, IPAddress(192, 168, 1, 10), 9001);
//   void setup() {
//     (join the network)
//     flow.begin("robot", "00112233445566778899aabbccddeeff", "esp32");  // user, key, client
//   }
//   void loop() { flow.poll(); ... }
//
// The account is the key's: the hub takes no other (and no password). Callbacks run inside
// poll(). Nonces come from random() mixed with micros(): on an ESP32 random() is the hardware
// generator; elsewhere call randomSeed() with something that differs at every start.
#ifndef SKROBOT_FLOW_UDP_ARDUINO_H
#define SKROBOT_FLOW_UDP_ARDUINO_H

#include <Arduino.h>
#include <Udp.h>

#include "SkRobotFlowBase.h"
#include "skr_siphash.h"
#include "skr_udp_link.h"

class SkRobotFlowUdp : public SkRobotFlowBase {
 public:
  // The hub at hub:port (server.udp). local_port: the board's own port (0: any, 4210 if the UDP
  // class needs one).
  SkRobotFlowUdp(UDP& udp, IPAddress hub, uint16_t port, uint16_t local_port = 4210)
      : udp_(udp), hub_(hub), port_(port), local_port_(local_port) {}

  // key_hex: the 32 hex digits `skrobot user key` printed. Strings are kept, not copied: pass
  // literals. false when the key is not 32 hex digits or the UDP class has no socket left. The
  // handshake starts at the first poll().
  bool begin(const char* user, const char* key_hex, const char* client_name);
  bool begin(const char* user, const uint8_t key[16], const char* client_name);
  // channel(), service(), subscribe(), follow(), publish(), setVar() ...: SkRobotFlowBase.h.

  // Reads the datagrams waiting and runs the session.
  void poll();
  // The UDP session's counters (handshakes, sessions, closes; link().s.stats: MACs, losses).
  const skr_udp_link& link() const { return link_; }

 private:
  static void send(void* ctx, const uint8_t* head, size_t head_n, const uint8_t* body,
                   size_t body_n, const uint8_t* tail, size_t tail_n);
  static void random(void* ctx, uint8_t* out, size_t n);
  static uint32_t clock(void* ctx);
  void receive(int n);

  UDP& udp_;
  IPAddress hub_;
  uint16_t port_, local_port_;
  skr_udp_link link_;
};

// Defined here, not in a .cpp: every .cpp of a library is linked into every sketch, and this code
// pulls IPAddress from the core (440 B of flash and 12 B of RAM on an Uno) into serial sketches
// that never use it.

inline int skrHexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

inline bool SkRobotFlowUdp::begin(const char* user, const char* key_hex, const char* client_name) {
  uint8_t key[16];
  for (uint8_t i = 0; i < 16; ++i) {
    const int hi = skrHexDigit(key_hex[2 * i]);
    const int lo = hi < 0 ? -1 : skrHexDigit(key_hex[2 * i + 1]);
    if (lo < 0) return false;
    key[i] = (uint8_t)(hi << 4 | lo);
  }
  if (key_hex[32] != '\0') return false;
  return begin(user, key, client_name);
}

inline bool SkRobotFlowUdp::begin(const char* user, const uint8_t key[16],
                                  const char* client_name) {
  skr_udp_port p;
  p.ctx = this;
  p.send = send;
  p.random = random;
  p.millis = clock;
  skr_udp_link_init(&link_, &flow_, &p, user, key, client_name);
  return udp_.begin(local_port_) != 0;
}

// One datagram, piece by piece: the UDP class gathers them (no copy here).
inline void SkRobotFlowUdp::send(void* ctx, const uint8_t* head, size_t head_n, const uint8_t* body,
                                 size_t body_n, const uint8_t* tail, size_t tail_n) {
  SkRobotFlowUdp& f = *static_cast<SkRobotFlowUdp*>(ctx);
  if (!f.udp_.beginPacket(f.hub_, f.port_)) return;
  f.udp_.write(head, head_n);
  if (body_n > 0) f.udp_.write(body, body_n);
  if (tail_n > 0) f.udp_.write(tail, tail_n);
  f.udp_.endPacket();
}

// A nonce: random() and micros() through SipHash keyed with the board's key, so that even a weak
// random() gives a value no one predicts without the key and a restart does not repeat it.
inline void SkRobotFlowUdp::random(void* ctx, uint8_t* out, size_t n) {
  SkRobotFlowUdp& f = *static_cast<SkRobotFlowUdp*>(ctx);
  uint8_t seed[12];
  for (uint8_t i = 0; i < 4; ++i) {
    const uint32_t r = (uint32_t)::random(0x7FFFFFFFL);
    seed[i] = (uint8_t)r;
    seed[4 + i] = (uint8_t)(r >> 8);
  }
  const uint32_t t = micros();
  for (uint8_t i = 0; i < 4; ++i) seed[8 + i] = (uint8_t)(t >> (8 * i));
  uint8_t mac[8];
  skr_siphash(f.link_.s.key, seed, sizeof seed, mac, 8);
  for (size_t i = 0; i < n; ++i) out[i] = mac[i % 8];
}

inline uint32_t SkRobotFlowUdp::clock(void*) {
  return millis();
}

// A datagram of n bytes from the hub: a handshake answer whole (38 bytes at most), a DATA's frame
// into the session's own receive buffer (no second buffer), then its MAC.
inline void SkRobotFlowUdp::receive(int n) {
  uint8_t head[SKR_UDP_ACCEPT_BYTES];
  if (!(udp_.remoteIP() == hub_) || udp_.remotePort() != port_) return;  // not the hub
  if (n < (int)SKR_UDP_HEAD_BYTES || udp_.read(head, SKR_UDP_HEAD_BYTES) != SKR_UDP_HEAD_BYTES) {
    ++link_.s.stats.other;
    return;
  }
  if ((head[0] == SKR_UDP_COOKIE || head[0] == SKR_UDP_ACCEPT) && n <= (int)sizeof head) {
    const int rest = n - (int)SKR_UDP_HEAD_BYTES;
    if (udp_.read(head + SKR_UDP_HEAD_BYTES, rest) == rest) skr_udp_link_input(&link_, head, n);
    return;
  }
  const int frame_n = n - (int)SKR_UDP_DATA_OVERHEAD;
  uint8_t* frame = skr_frame_buffer(&flow_);
  uint8_t mac[8];
  if (frame_n < 0 || frame_n > (int)SKR_RX_BUF) {
    ++link_.s.stats.other;  // a frame above SKR_RX_MAX: the hub keeps them away (SESSION_LIMITS)
    return;
  }
  if (udp_.read(frame, frame_n) != frame_n || udp_.read(mac, 8) != 8) return;
  skr_udp_link_input_parts(&link_, head, frame, (size_t)frame_n, mac);
}

inline void SkRobotFlowUdp::poll() {
  int n;
  while ((n = udp_.parsePacket()) > 0) receive(n);
  skr_udp_link_poll(&link_);
}

#endif  // SKROBOT_FLOW_UDP_ARDUINO_H
