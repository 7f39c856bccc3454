// SPDX-License-Identifier: Apache-2.0
// A WiFi library of nothing, for the Uno (which has no radio): the UDP examples build as they
// would for an ESP32, so that the board library's size over UDP is measured (bench/board_size).
// Its WiFiUDP moves bytes through one volatile register, so the compiler keeps every path that
// reads and writes datagrams.
#ifndef NULL_WIFI_H
#define NULL_WIFI_H

#include <Arduino.h>

enum { WL_CONNECTED = 3 };

class NullWiFi {
 public:
  void begin(const char*, const char*) {}
  int status() { return WL_CONNECTED; }
};
extern NullWiFi WiFi;

#endif
